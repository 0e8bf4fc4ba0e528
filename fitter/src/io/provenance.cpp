// provenance.cpp -- tool version, commit, command line and input digests (see provenance.hpp).
#include "indicial/fitter/provenance.hpp"

#include <openssl/evp.h>

#include <cstdio>
#include <fmt/format.h>
#include <fstream>
#include <memory>
#include <sstream>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/version.hpp"

namespace indicial {

const char* tool_version() { return INDICIAL_VERSION; }

std::string version_line(const std::string& commit) {
  if (commit.empty() || commit == "unknown") return std::string("indicial ") + tool_version();
  return std::string("indicial ") + tool_version() + " (commit " + commit + ")";
}

std::string sha256_hex(const std::string& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  // EVP_Digest: one-shot, OpenSSL's maintained implementation.
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &n, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("OpenSSL EVP_Digest(SHA-256) failed");
  std::string hex;
  hex.reserve(2 * n);
  for (unsigned int i = 0; i < n; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

std::string sha256_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot be read (for its SHA-256)");
  std::ostringstream ss;
  ss << in.rdbuf();
  return sha256_hex(ss.str());
}

Provenance make_provenance(const std::string& command_line, const std::string& commit) {
  Provenance p;
  p.version = tool_version();
  p.commit = commit.empty() ? "unknown" : commit;
  p.command_line = command_line;
  return p;
}

void add_input(Provenance& p, const std::string& role, const std::string& path) {
  p.inputs.push_back({role, path, sha256_file(path)});
}

std::vector<std::string> experiment_input_paths(const Experiment& e) {
  std::vector<std::string> paths = {e.path};
  // A run of several files (files = [...]) has a label as its path: each file instead.
  for (const Run& r : e.runs) {
    if (r.source_files.empty()) paths.push_back(r.path);
    paths.insert(paths.end(), r.source_files.begin(), r.source_files.end());
  }
  if (e.static_curve.kind == StaticKind::table && !e.static_curve.table_path.empty())
    paths.push_back(e.static_curve.table_path);
  if (!e.model.stall.polar_path.empty()) paths.push_back(e.model.stall.polar_path);
  return paths;
}

Provenance experiment_provenance(const Experiment& e, const std::string& command_line,
                                 const std::string& commit) {
  Provenance p = make_provenance(command_line, commit);
  add_input(p, "experiment", e.path);
  // A run of several files (files = [...]) has a label as its path: digest each file.
  for (const Run& r : e.runs) {
    if (r.source_files.empty()) add_input(p, "run", r.path);
    for (const std::string& f : r.source_files) add_input(p, "run", f);
  }
  if (e.static_curve.kind == StaticKind::table && !e.static_curve.table_path.empty())
    add_input(p, "static_table", e.static_curve.table_path);
  return p;
}

nlohmann::json provenance_json(const Provenance& p) {
  nlohmann::json inputs = nlohmann::json::array();
  for (const InputDigest& d : p.inputs)
    inputs.push_back({{"role", d.role}, {"path", d.path}, {"sha256", d.sha256}});
  return {{"tool", "indicial"},
          {"version", p.version},
          {"commit", p.commit},
          {"command_line", p.command_line},
          {"inputs", inputs}};
}

namespace {

// One comment line's text: no line breaks can leak into the coefficient file.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

std::string with_provenance_header(const std::string& coef_text, const Provenance& p) {
  if (p.version.empty()) return coef_text;
  const std::size_t at = coef_text.rfind("\nchecksum ");
  if (at == std::string::npos) throw std::logic_error("with_provenance_header: no checksum line");
  std::string text = "# " + version_line(p.commit) + "\n";
  if (!p.command_line.empty()) text += "# command: " + one_line(p.command_line) + "\n";
  for (const InputDigest& d : p.inputs)
    text += "# input " + d.role + " sha256 " + d.sha256 + " " + one_line(d.path) + "\n";
  text += "# units: every polynomial and knot of the model angle x is in rad; b and con in 1/s at airspeed_mps\n";
  text.append(coef_text, 0, at + 1);
  // Why recompute: the checksum covers every byte before its line, comments included.
  text += fmt::format("checksum {:08x}\n", crc32(text.data(), text.size()));
  return text;
}

std::string strip_provenance_header(const std::string& coef_text) {
  std::size_t begin = 0;
  while (begin < coef_text.size() && coef_text[begin] == '#') {
    const std::size_t nl = coef_text.find('\n', begin);
    begin = nl == std::string::npos ? coef_text.size() : nl + 1;
  }
  const std::size_t at = coef_text.rfind("\nchecksum ");
  const std::size_t end = at == std::string::npos || at < begin ? coef_text.size() : at + 1;
  return coef_text.substr(begin, end - begin);
}

}  // namespace indicial
