#include "indicial/fitter/output.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include "indicial/fitter/error.hpp"

namespace fs = std::filesystem;

namespace indicial {
namespace {

std::string unique_suffix() {
  static int counter = 0;
  return std::to_string(::getpid()) + "-" + std::to_string(++counter);
}

// Writes text to `actual`; a failure is reported against `reported` (what the user asked for)
// with `consequence` appended, e.g. "; out/ left as it was".
void write_text_as(const fs::path& actual, const std::string& text, const fs::path& reported,
                   const std::string& consequence) {
  std::ofstream out(actual, std::ios::binary | std::ios::trunc);
  if (!out)
    throw InputError(reported.string(), 0,
                     std::string("cannot open for writing: ") + std::strerror(errno) + consequence);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.flush();
  if (!out)
    throw InputError(reported.string(), 0, std::string("write failed: ") + std::strerror(errno) + consequence);
  out.close();
  if (!out)
    throw InputError(reported.string(), 0,
                     std::string("write failed on close: ") + std::strerror(errno) + consequence);
}

bool is_nonempty_dir(const fs::path& p) {
  std::error_code ec;
  if (!fs::exists(p, ec)) return false;
  if (!fs::is_directory(p, ec)) return true;  // a file in the way counts as "not empty"
  return fs::directory_iterator(p, ec) != fs::directory_iterator();
}

// `inner` is `dir` or inside it (both made absolute and normal; symbolic links resolved where
// they exist).
bool is_within(const fs::path& inner, const fs::path& dir) {
  std::error_code ec;
  const fs::path a = fs::weakly_canonical(fs::absolute(inner, ec), ec);
  const fs::path d = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  auto ai = a.begin();
  for (auto di = d.begin(); di != d.end(); ++di, ++ai) {
    if (di->empty()) continue;  // a trailing separator
    if (ai == a.end() || *ai != *di) return false;
  }
  return true;
}

// --force replaces a directory's whole contents: never one that holds the command's own input
// or the working directory (`--out .`), whose loss the user did not ask for.
void refuse_replacing_inputs(const fs::path& final_dir, const std::vector<std::string>& inputs) {
  for (const std::string& in : inputs)
    if (!in.empty() && is_within(in, final_dir))
      throw InputError(final_dir.string(), 0, "--force would replace this directory's contents, and it holds an "
                                              "input of this command (" + in + "): choose another --out");
  std::error_code ec;
  if (is_within(fs::current_path(ec), final_dir))
    throw InputError(final_dir.string(), 0, "--force would replace this directory's contents, and it is (or holds) "
                                            "the working directory: choose another --out");
}

// Every regular file under dir, relative, in generic form ("plots/a.dat"), sorted; the manifest
// itself left out.
std::vector<std::string> files_under(const fs::path& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ec2;
    if (it->is_directory(ec2)) continue;
    const std::string rel = fs::relative(it->path(), dir, ec2).generic_string();
    if (rel != kOutputManifest) files.push_back(rel);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The files a previous commit() listed in dir's manifest (empty set when there is none).
std::set<std::string> manifest_files(const fs::path& dir, bool* present) {
  std::set<std::string> listed;
  std::ifstream in(dir / kOutputManifest);
  *present = static_cast<bool>(in);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') listed.insert(line);
  return listed;
}

// --force replaces what indicial wrote, never a file it did not: a directory whose files are
// not all in its manifest (a user's notes added after a fit, a folder of data named by mistake)
// is refused, naming them. Why not keep those files and replace the rest: the directory is
// swapped whole (outputs appear whole or not at all), and leaving stale outputs of another
// run beside new ones would mislead.
void refuse_replacing_foreign_files(const fs::path& final_dir) {
  bool present = false;
  const std::set<std::string> listed = manifest_files(final_dir, &present);
  std::vector<std::string> foreign;
  for (const std::string& f : files_under(final_dir))
    if (!listed.count(f)) foreign.push_back(f);
  if (foreign.empty()) return;
  std::string names;
  const std::size_t shown = std::min<std::size_t>(foreign.size(), 5);
  for (std::size_t i = 0; i < shown; ++i) names += (i ? ", " : "") + foreign[i];
  if (foreign.size() > shown) names += " and " + std::to_string(foreign.size() - shown) + " more";
  throw InputError(final_dir.string(), 0,
                   std::string("--force replaces only a directory of indicial's outputs, and this one holds ") +
                       (present ? "files indicial did not write there (not in its " + std::string(kOutputManifest) + "): "
                                : "files indicial did not write (it has no " + std::string(kOutputManifest) + "): ") +
                       names + "; move them, or choose another --out");
}

}  // namespace

OutputDir::OutputDir(const fs::path& final_dir, Overwrite overwrite, const std::vector<std::string>& inputs)
    : final_(final_dir), overwrite_(overwrite) {
  std::error_code ec;
  if (fs::exists(final_, ec) && !fs::is_directory(final_, ec)) {
    throw InputError(final_.string(), 0, "output path exists and is not a directory");
  }
  if (is_nonempty_dir(final_) && overwrite_ == Overwrite::refuse) {
    throw InputError(final_.string(), 0,
                     "output directory is not empty (use --force to replace its contents)");
  }
  if (is_nonempty_dir(final_)) {
    refuse_replacing_inputs(final_, inputs);
    refuse_replacing_foreign_files(final_);
  }
  fs::path parent = final_.has_parent_path() ? final_.parent_path() : fs::path(".");
  if (parent.empty()) parent = ".";
  fs::create_directories(parent, ec);
  if (ec) throw InputError(parent.string(), 0, "cannot create directory: " + ec.message());
  staging_ = parent / ("." + final_.filename().string() + ".staging-" + unique_suffix());
  fs::create_directory(staging_, ec);
  if (ec) throw InputError(staging_.string(), 0, "cannot create directory: " + ec.message());
}

OutputDir::~OutputDir() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
}

fs::path OutputDir::path(const std::string& name) const { return staging_ / name; }

void OutputDir::write(const std::string& relative_name, const std::string& text) const {
  const fs::path actual = staging_ / relative_name;
  std::error_code ec;
  if (actual.has_parent_path()) fs::create_directories(actual.parent_path(), ec);
  write_text_as(actual, text, final_ / relative_name,
                fs::exists(final_, ec) ? "; " + final_.string() + " left as it was"
                                       : "; " + final_.string() + " was not created");
}

void OutputDir::commit() {
  std::error_code ec;
  // The manifest: what --force may later replace (refuse_replacing_foreign_files).
  std::string manifest = "# written by indicial: the files of this directory it wrote. --force replaces the\n"
                         "# directory only while every file in it is listed here.\n";
  for (const std::string& f : files_under(staging_)) manifest += f + "\n";
  write(kOutputManifest, manifest);
  fs::path old;
  if (fs::exists(final_, ec)) {
    if (is_nonempty_dir(final_) && overwrite_ == Overwrite::refuse) {
      throw InputError(final_.string(), 0,
                       "output directory became non-empty while writing; results left in " +
                           staging_.string());
    }
    old = final_.parent_path() / ("." + final_.filename().string() + ".old-" + unique_suffix());
    if (final_.parent_path().empty()) old = fs::path("." + final_.filename().string() + ".old-" + unique_suffix());
    fs::rename(final_, old, ec);
    if (ec) throw InputError(final_.string(), 0, "cannot move previous results aside: " + ec.message());
  }
  fs::rename(staging_, final_, ec);
  if (ec) {
    std::error_code ec2;
    if (!old.empty()) fs::rename(old, final_, ec2);
    throw InputError(final_.string(), 0, "cannot move results into place: " + ec.message());
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

void write_text(const fs::path& path, const std::string& text) { write_text_as(path, text, path, ""); }

void refuse_output_onto_input(const fs::path& output, const std::vector<std::string>& inputs) {
  std::error_code ec;
  if (output.empty() || !fs::exists(output, ec)) return;
  for (const std::string& in : inputs)
    if (!in.empty() && fs::equivalent(output, in, ec))
      throw InputError(output.string(), 0, "is an input of this command (" + in + "): --force replaces outputs, "
                                           "never what was read; choose another output name");
}

void write_file_atomically(const fs::path& path, Overwrite overwrite,
                           const std::function<void(const fs::path& tmp)>& produce) {
  std::error_code ec;
  // A directory is never replaced by a file, --force or not (it said "output file exists").
  if (fs::is_directory(path, ec))
    throw InputError(path.string(), 0, "is a directory, expected the name of a file to write");
  if (fs::exists(path, ec) && overwrite == Overwrite::refuse) {
    throw InputError(path.string(), 0, "output file exists (use --force to replace it)");
  }
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  fs::path tmp = path;
  tmp += ".tmp-" + unique_suffix();
  try {
    produce(tmp);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  if (!fs::exists(tmp, ec)) {
    throw InputError(path.string(), 0,
                     fs::exists(path, ec) ? "nothing was produced; " + path.string() + " left as it was"
                                          : "nothing was produced; " + path.string() + " was not created");
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ec2;
    fs::remove(tmp, ec2);
    throw InputError(path.string(), 0, "cannot move output into place: " + ec.message());
  }
}

void write_file_atomically(const fs::path& path, const std::string& text, Overwrite overwrite) {
  write_file_atomically(path, overwrite, [&](const fs::path& tmp) {
    std::error_code ec;
    // Reported against `path`: the temporary is removed, and `path` is what was asked for.
    write_text_as(tmp, text, path,
                  fs::exists(path, ec) ? "; " + path.string() + " left as it was"
                                       : "; " + path.string() + " was not created");
  });
}

std::string read_text(const fs::path& path) {
  std::error_code ec;
  // Named as such: a directory opens as an empty stream and read as "empty input".
  if (fs::is_directory(path, ec)) throw InputError(path.string(), 0, "is a directory, expected a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot open file (does it exist?)");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path.string(), 0, "read failed");
  return ss.str();
}

}  // namespace indicial
