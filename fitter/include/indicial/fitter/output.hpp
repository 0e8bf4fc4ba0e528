// indicial/fitter/output.hpp -- outputs appear whole or not at all.
//
// Every command that writes results goes through these two helpers:
//
//   OutputDir out(dir, Overwrite::refuse);    // throws InputError if dir exists and is not empty
//   out.write("fit.json", json);              // written into a hidden staging directory
//   out.commit();                             // renamed into place in one step
//
//   write_file_atomically(path, text, Overwrite::refuse);   // single files: temp + rename
//   write_file_atomically(path, Overwrite::refuse, [&](const fs::path& tmp) { ... });
//                                     // a file another program makes (a gnuplot PNG): same rules
//
// These are the ONE place where outputs are staged and renamed: no command or layer writes its
// own temp-file-then-rename.
//
// Warnings
// 1. If commit() is never called (an exception, a crash) the staging directory is removed by
//    the destructor and the previous contents of dir are untouched.
// 2. With Overwrite::replace an existing dir is moved aside, the new one renamed in, and the
//    old one deleted; a failure before the second rename puts the old one back.
// 3. Error messages name the output the user asked for (DIR/fit.json, out.csv), never the
//    staging or temporary name, which is gone by the time the message is read.
// 4. commit() writes a manifest, DIR/.indicial-outputs, listing every file it put there. With
//    Overwrite::replace a non-empty DIR is replaced only when each of its files is listed in
//    it: a file indicial did not write there (a user's notes added later, a data folder given
//    as --out by mistake) is refused by name, and nothing is touched.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace indicial {

enum class Overwrite { refuse, replace };

// The manifest OutputDir::commit writes into every output directory (Warning 4).
inline constexpr const char* kOutputManifest = ".indicial-outputs";

class OutputDir {
 public:
  // inputs: the files the command read (experiment, runs, tables). With Overwrite::replace a
  // non-empty final_dir that holds one of them, or the working directory, or any file not in
  // its manifest (Warning 4) is refused: --force replaces the directory's whole contents, and
  // such a file inside it would be lost.
  OutputDir(const std::filesystem::path& final_dir, Overwrite overwrite,
            const std::vector<std::string>& inputs = {});
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  // Where to write `name` now (inside the staging directory).
  std::filesystem::path path(const std::string& name) const;
  // Writes text to path(relative_name), creating its parent directories (e.g. "plots/a.dat").
  // A failure throws InputError naming final_dir()/relative_name and saying that final_dir()
  // was left as it was.
  void write(const std::string& relative_name, const std::string& text) const;
  const std::filesystem::path& staging_dir() const { return staging_; }
  const std::filesystem::path& final_dir() const { return final_; }
  void commit();

 private:
  std::filesystem::path final_;
  std::filesystem::path staging_;
  Overwrite overwrite_;
  bool committed_ = false;
};

// Throws InputError when `output` exists and is one of `inputs` (the same file, by any name):
// --force replaces outputs, never what the command read (`predict ... --out data.csv --force`
// replaced the measured cycle it predicted). Paths that do not exist are skipped.
void refuse_output_onto_input(const std::filesystem::path& output, const std::vector<std::string>& inputs);

// Writes text to path (throws InputError naming the path on any failure, e.g. a full disk).
// Non-atomic: for outputs use OutputDir::write or write_file_atomically.
void write_text(const std::filesystem::path& path, const std::string& text);

// Writes text to path.tmp-<pid>-<n> and renames it to path; refuses an existing path unless
// overwrite == Overwrite::replace.
void write_file_atomically(const std::filesystem::path& path, const std::string& text,
                           Overwrite overwrite);

// The same for an output that something else produces: refuses an existing path unless
// overwrite == Overwrite::replace, creates path's parent directories, calls produce(tmp) with a
// temporary sibling of path (path.tmp-<pid>-<n>), then renames tmp to path. If produce throws
// or leaves tmp missing, tmp is removed and path is left as it was (produce's InputError
// propagates; a missing tmp throws InputError naming path).
void write_file_atomically(const std::filesystem::path& path, Overwrite overwrite,
                           const std::function<void(const std::filesystem::path& tmp)>& produce);

// Reads a whole file (throws InputError naming the path if it cannot be read).
std::string read_text(const std::filesystem::path& path);

}  // namespace indicial
