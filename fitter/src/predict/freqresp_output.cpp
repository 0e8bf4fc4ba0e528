// The frequency response's outputs: CSV table and plot. See
// indicial/fitter/freqresp_output.hpp.
#include "indicial/fitter/freqresp_output.hpp"

#include <sstream>

#include "indicial/fitter/gnuplot.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

// The plot's gnuplot script (two panels: in-phase and out-of-phase against k), drawing into
// `output`.
std::string frequency_response_plot_script(const std::vector<FrequencyResponse>& r, const std::string& output,
                                           const std::string& title) {
  std::ostringstream s;
  s.precision(10);
  for (std::size_t c = 0; c < r.size(); ++c) {
    s << "$d" << c << " << EOD\n";
    for (const auto& p : r[c].points) s << p.k << ' ' << p.in_phase << ' ' << p.out_of_phase << '\n';
    s << "EOD\n";
  }
  s << "set terminal pngcairo size 1100,420 font 'sans,10'\nset output " << gnuplot_quote(output) << "\n";
  s << "set grid\nset key top right\nset xlabel 'reduced frequency k = omega l / V'\n";
  s << "set multiplot layout 1,2 title " << gnuplot_quote(title) << "\n";
  for (int panel = 0; panel < 2; ++panel) {
    s << "set ylabel '" << (panel == 0 ? "in-phase Re H, per rad" : "out-of-phase Im H / k, per rad") << "'\n";
    s << "plot ";
    for (std::size_t c = 0; c < r.size(); ++c)
      s << (c ? ", " : "") << "$d" << c << " using 1:" << (panel == 0 ? 2 : 3)
        << " with linespoints lw 1.5 title " << gnuplot_quote(r[c].coefficient);
    s << "\n";
  }
  s << "unset multiplot\nset output\n";
  return s.str();
}

}  // namespace

std::string frequency_response_csv(const std::vector<FrequencyResponse>& r,
                                   const std::vector<std::string>& comment_lines) {
  std::string s;
  for (const auto& c : comment_lines) s += "# " + c + "\n";
  s += "coefficient,k,freq_hz,in_phase_per_rad,out_of_phase_per_rad,magnitude,phase_deg,re,im\n";
  for (const auto& c : r) {
    for (const auto& p : c.points) {
      s += c.coefficient + "," + format_double(p.k) + "," + format_double(p.freq_hz) + "," +
           format_double(p.in_phase) + "," + format_double(p.out_of_phase) + "," +
           format_double(p.magnitude) + "," + format_double(p.phase_deg) + "," +
           format_double(p.h.real()) + "," + format_double(p.h.imag()) + "\n";
    }
  }
  return s;
}

void write_frequency_response_plot(const std::vector<FrequencyResponse>& r, const std::string& png_path,
                                   const std::string& title, Overwrite overwrite, const std::string& gnuplot) {
  write_gnuplot_png(png_path,
                    [&](const std::string& output) { return frequency_response_plot_script(r, output, title); },
                    gnuplot, overwrite);
}

}  // namespace indicial
