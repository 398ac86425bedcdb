#include "device/kernel_source.h"

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "util/errors.h"

namespace spm {
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw RuntimeError("cannot read kernel source " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `chain` holds the files being expanded, to stop include cycles; a header is
// otherwise inlined at every include, as its own guard decides what survives
// (an include inside an inactive #if branch must not hide a later active one).
void expand(const fs::path& path, const std::vector<std::string>& dirs, std::set<fs::path>& chain,
            std::string& out) {
  const fs::path canonical = fs::weakly_canonical(path);
  if (!chain.insert(canonical).second) return;
  static const std::regex include_re(R"re(^\s*#\s*include\s*"([^"]+)")re");
  std::istringstream in(read_text(path));
  std::string line;
  int number = 0;
  out += "#line 1 \"" + path.filename().string() + "\"\n";
  while (std::getline(in, line)) {
    ++number;
    std::smatch m;
    if (!std::regex_search(line, m, include_re)) {
      out += line;
      out += '\n';
      continue;
    }
    fs::path found;
    std::vector<fs::path> candidates{path.parent_path() / m[1].str()};
    for (const auto& d : dirs) candidates.push_back(fs::path(d) / m[1].str());
    for (const auto& c : candidates) {
      if (fs::exists(c)) {
        found = c;
        break;
      }
    }
    if (found.empty()) {
      // Left for the device compiler: Random123 names headers of other
      // compilers inside #if branches that OpenCL never takes.
      out += line;
      out += '\n';
      continue;
    }
    expand(found, dirs, chain, out);
    out += "#line " + std::to_string(number + 1) + " \"" + path.filename().string() + "\"\n";
  }
  chain.erase(canonical);
}

}  // namespace

std::string expand_kernel_source(const std::string& path, const std::vector<std::string>& search_dirs) {
  std::set<fs::path> chain;
  std::string out;
  expand(path, search_dirs, chain, out);
  return out;
}

}  // namespace spm
