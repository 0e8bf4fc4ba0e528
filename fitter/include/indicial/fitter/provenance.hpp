// indicial/fitter/provenance.hpp -- where an output came from: tool version, commit, command
// line and the SHA-256 of every input file.
//
// What it is for
// --------------
// A fit.json, diagnosis.json or model.coef found on a disk months later must say which
// indicial made it, from which command and from exactly which bytes. Every command that
// writes results builds one Provenance and hands it to its writers:
//
//   fit.json, diagnosis.json   "provenance": {"tool": "indicial", "version": "0.1.0",
//                               "commit": "3f2c...", "command_line": "indicial fit ...",
//                               "inputs": [{"role": "experiment", "path": "...",
//                                           "sha256": "64 hex digits"}, ...]}
//   model.coef                 `#` comment lines before the body (the coefficient format
//                               allows comments; the checksum covers them, so it is
//                               recomputed): `# indicial 0.1.0 (commit 3f2c...)`,
//                               `# command: ...`, `# input experiment SHA256 PATH`, ...,
//                               `# units: ...` (x in rad for every polynomial and knot)
//
// Usage
// -----
//   indicial::Provenance p =
//       indicial::experiment_provenance(e, "indicial fit exp.toml --out d", commit);
//   json["provenance"] = indicial::provenance_json(p);
//   coef_text = indicial::with_provenance_header(coef_text, p);
//   std::puts(indicial::version_line(commit).c_str());   // "indicial 0.1.0 (commit 3f2c...)"
//
// Warnings
// --------
// 1. The version is the root CMakeLists.txt's project(VERSION) (cmake/version.cmake); nothing
//    else may spell it. The commit is read from git at build time by the command line
//    (tools/build_commit.cpp: "unknown" outside a git checkout, "-dirty" when the tree had
//    uncommitted changes) and passed in here; the library does not embed it, so a new commit
//    relinks one executable, not every test.
// 2. Digests are of the files as they are on disk when the provenance is made (just after
//    load_experiment read them); SHA-256 comes from OpenSSL's libcrypto, never hand-written.
// 3. Two outputs made from the same inputs by different command lines or builds differ in
//    their provenance lines only: compare model.coef files with strip_provenance_header().
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "indicial/fitter/experiment.hpp"

namespace indicial {

// "0.1.0": the project version.
const char* tool_version();
// "indicial 0.1.0 (commit 3f2c1a9b8d7e)", or "indicial 0.1.0" when commit is "unknown" or "".
std::string version_line(const std::string& commit);

// SHA-256 of bytes / of a file's contents as 64 lowercase hex digits. sha256_file throws
// InputError naming the path if it cannot be read.
std::string sha256_hex(const std::string& bytes);
std::string sha256_file(const std::filesystem::path& path);

struct InputDigest {
  std::string role;    // "experiment", "run", "static_table", "model", "data"
  std::string path;    // as the command was given it (or as the experiment resolved it)
  std::string sha256;  // 64 hex digits
};

struct Provenance {
  std::string version;       // tool_version()
  std::string commit;        // the build's commit (12 hex digits[-dirty]) or "unknown"
  std::string command_line;  // the whole invocation, shell-quoted where needed
  std::vector<InputDigest> inputs;
};

// The version, commit and command line, no inputs yet.
Provenance make_provenance(const std::string& command_line, const std::string& commit);
// Appends an input with its digest (reads the file).
void add_input(Provenance& p, const std::string& role, const std::string& path);
// Every file an experiment was read from: the experiment, each run's file(s), the static table
// and the stall polar (if any). For provenance, and for outputs that must not replace them.
std::vector<std::string> experiment_input_paths(const Experiment& e);
// make_provenance plus the experiment file, every run CSV and the static table (if any).
Provenance experiment_provenance(const Experiment& e, const std::string& command_line,
                                 const std::string& commit);

nlohmann::json provenance_json(const Provenance& p);

// coef_text (a complete coefficient file, ending with its checksum line) with the provenance
// as `#` comment lines before the body and the checksum recomputed over the new bytes. An
// empty Provenance (no version) returns coef_text unchanged.
std::string with_provenance_header(const std::string& coef_text, const Provenance& p);
// The file without the leading comment lines written by with_provenance_header and without
// its checksum line: the content to compare between two model.coef files.
std::string strip_provenance_header(const std::string& coef_text);

}  // namespace indicial
