// Writers of run CSVs and the shortest-round-trip number format. See indicial/fitter/io.hpp.
#include "indicial/fitter/io.hpp"

#include <charconv>
#include <stdexcept>

namespace indicial {

std::string format_double(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string write_run_csv(const std::vector<CsvColumn>& columns,
                          const std::vector<std::string>& comment_lines) {
  std::string out;
  for (const auto& c : comment_lines) out += "# " + c + "\n";
  const std::size_t n = columns.empty() ? 0 : columns.front().values.size();
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].values.size() != n) {
      throw std::invalid_argument("write_run_csv: column '" + columns[c].name +
                                  "' has a different length");
    }
    out += (c ? "," : "") + columns[c].name;
  }
  out += "\n";
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c) out += ',';
      out += format_double(columns[c].values[i]);
    }
    out += '\n';
  }
  return out;
}

}  // namespace indicial
