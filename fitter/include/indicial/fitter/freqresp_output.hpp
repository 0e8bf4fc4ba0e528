// indicial/fitter/freqresp_output.hpp -- what `indicial freqresp` writes: the CSV table and
// the plot of a linearised frequency response (freqresp.hpp computes it; this header only
// words and draws it). The plot goes through write_gnuplot_png (gnuplot.hpp), so it is
// written atomically and with the gnuplot the user names.
#pragma once

#include <string>
#include <vector>

#include "indicial/fitter/freqresp.hpp"
#include "indicial/fitter/output.hpp"

namespace indicial {

// CSV text: coefficient, k, freq_hz, in_phase_per_rad, out_of_phase_per_rad, magnitude,
// phase_deg, re, im.
std::string frequency_response_csv(const std::vector<FrequencyResponse>& r,
                                   const std::vector<std::string>& comment_lines);

// Two panels against k (in-phase Re H, out-of-phase Im H / k), one curve per coefficient,
// written atomically to png_path (refuses an existing file unless overwrite). Throws
// InputError naming png_path when gnuplot cannot be run or fails.
void write_frequency_response_plot(const std::vector<FrequencyResponse>& r, const std::string& png_path,
                                   const std::string& title, Overwrite overwrite,
                                   const std::string& gnuplot = "gnuplot");

}  // namespace indicial
