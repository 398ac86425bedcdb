#include "scene/xml_context.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "util/errors.h"

namespace spm::xml {

namespace fs = std::filesystem;

std::string read_text_file(const std::string& path, const std::string& where, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(where, what + " '" + path + "' does not exist");
  if (fs::is_directory(path, ec)) throw InputError(where, what + " '" + path + "' is a directory, not a file");
  // A device such as /dev/zero never ends; pipes (e.g. <(...)) are fine.
  if (fs::is_character_file(path, ec) || fs::is_block_file(path, ec))
    throw InputError(where, what + " '" + path + "' is a device, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(where, "cannot read " + what + " '" + path + "': " + std::strerror(errno));
  std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw InputError(where, "cannot read " + what + " '" + path + "': " + std::strerror(errno));
  return text;
}

int Context::Source::line_of(ptrdiff_t offset) const {
  if (offset < 0) return 0;
  auto it = std::upper_bound(line_starts.begin(), line_starts.end(), static_cast<size_t>(offset));
  return static_cast<int>(it - line_starts.begin());
}

Context::Context(std::map<std::string, std::string> overrides) : overrides_(std::move(overrides)) {}

pugi::xml_node Context::push_source(const std::string& text, const std::string& name) {
  auto src = std::make_unique<Source>();
  src->name = name;
  src->dir = fs::path(name).parent_path().string();
  src->line_starts.push_back(0);
  for (size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\n') src->line_starts.push_back(i + 1);

  pugi::xml_parse_result result = src->doc.load_buffer(text.data(), text.size(), pugi::parse_default);
  if (!result) {
    throw InputError(name + ":" + std::to_string(src->line_of(result.offset)),
                     std::string("malformed XML: ") + result.description());
  }
  if (sources_.empty()) search_path_ = {src->dir, fs::current_path().string()};
  sources_.push_back(std::move(src));

  // pugixml reports a document without elements as a parse error, so there is a root.
  pugi::xml_node root = current().doc.document_element();
  for (pugi::xml_node n = root.next_sibling(); n; n = n.next_sibling())
    if (n.type() == pugi::node_element) fail(n, "a second top-level element <" + std::string(n.name()) + ">");
  if (std::string(root.name()) != "scene")
    fail(root, "the root element must be <scene>, not <" + std::string(root.name()) + ">");
  check_attributes(root, {"version"});
  // Mitsuba 3 reads files written for 2.x and 3.x as they are; older versions
  // used other property names.
  std::string version = attr(root, "version");
  int major = 0, minor = 0, patch = 0;
  char tail = 0;
  if (std::sscanf(version.c_str(), "%d.%d.%d%c", &major, &minor, &patch, &tail) != 3)
    fail(root, "malformed scene version '" + version + "' (expected e.g. \"3.0.0\")");
  if (major < 2 || major > 3)
    fail(root, "unsupported scene version '" + version + "' (Mitsuba 3 format, 2.x or 3.x, expected)");
  return root;
}

void Context::pop_source() { sources_.pop_back(); }

std::string Context::resolve(const std::string& name) const {
  if (fs::path(name).is_absolute()) return name;
  std::error_code ec;
  for (const std::string& base : search_path_) {
    fs::path candidate = fs::path(base) / name;
    if (fs::exists(candidate, ec)) return candidate.string();
  }
  return (fs::path(sources_.front()->dir) / name).string();
}

std::string Context::resolve_include(const std::string& name) const {
  std::error_code ec;
  fs::path beside = fs::path(current().dir) / name;
  if (fs::path(name).is_relative() && fs::exists(beside, ec)) return beside.string();
  return resolve(name);
}

void Context::add_search_path(const pugi::xml_node& node) {
  check_attributes(node, {"value"});
  const std::string value = attr(node, "value");
  if (value.empty()) fail(node, "<path> needs a folder in 'value'");
  std::error_code ec;
  fs::path folder = value;
  if (folder.is_relative()) {
    folder = fs::path(current().dir) / value;
    if (!fs::exists(folder, ec)) folder = resolve(value);
  }
  if (!fs::is_directory(folder, ec)) fail(node, "<path> folder '" + folder.string() + "' does not exist");
  search_path_.insert(search_path_.begin(), folder.string());
}

bool Context::is_open(const std::string& name) const {
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(name, ec);
  return std::any_of(sources_.begin(), sources_.end(), [&](const std::unique_ptr<Source>& s) {
    std::error_code ec2;
    return fs::weakly_canonical(s->name, ec2) == canonical;
  });
}

std::string Context::where(const pugi::xml_node& node) const {
  return current().name + ":" + std::to_string(current().line_of(node.offset_debug()));
}

void Context::fail(const pugi::xml_node& node, const std::string& problem) const {
  throw InputError(where(node), problem);
}

void Context::define_default(const pugi::xml_node& node) {
  check_attributes(node, {"name", "value"});
  if (pugi::xml_node child = node.first_child())
    fail(child.type() == pugi::node_element ? child : node, "<default> takes no content");
  std::string name = attr(node, "name");
  std::string value = attr(node, "value");
  if (name.empty()) fail(node, "<default> with an empty name");
  defaults_.emplace(name, value);
}

void Context::check_overrides(const pugi::xml_node& root) const {
  for (const auto& [name, value] : overrides_) {
    if (defaults_.count(name) == 0)
      throw InputError(where(root), "parameter '" + name + "' is set on the command line but the scene has no " +
                                        "<default name=\"" + name + "\">");
  }
}

std::string Context::substitute(const pugi::xml_node& node, const char* attribute, const std::string& raw) const {
  std::string out;
  size_t i = 0;
  while (i < raw.size()) {
    if (raw[i] != '$') {
      out += raw[i++];
      continue;
    }
    size_t end = i + 1;
    while (end < raw.size() && (std::isalnum(static_cast<unsigned char>(raw[end])) || raw[end] == '_')) ++end;
    std::string name = raw.substr(i + 1, end - i - 1);
    if (name.empty()) fail(node, "'$' without a parameter name in attribute '" + std::string(attribute) + "'");
    auto it = overrides_.find(name);
    if (it == overrides_.end()) it = defaults_.find(name);
    if (it == defaults_.end())
      fail(node, "unknown parameter '$" + name + "' in attribute '" + attribute + "' (no <default name=\"" + name +
                     "\"> before it)");
    out += it->second;
    i = end;
  }
  return out;
}

std::string Context::attr(const pugi::xml_node& node, const char* name) const {
  std::optional<std::string> value = opt_attr(node, name);
  if (!value) fail(node, "<" + std::string(node.name()) + "> needs the attribute '" + name + "'");
  return *value;
}

std::optional<std::string> Context::opt_attr(const pugi::xml_node& node, const char* name) const {
  pugi::xml_attribute a = node.attribute(name);
  if (!a) return std::nullopt;
  return substitute(node, name, a.value());
}

void Context::check_attributes(const pugi::xml_node& node, std::initializer_list<const char*> allowed) const {
  for (pugi::xml_attribute a : node.attributes()) {
    bool ok = std::any_of(allowed.begin(), allowed.end(), [&](const char* n) { return std::strcmp(n, a.name()) == 0; });
    if (!ok) fail(node, "unknown attribute '" + std::string(a.name()) + "' of <" + node.name() + ">");
  }
}

std::vector<pugi::xml_node> Context::elements(const pugi::xml_node& node) const {
  std::vector<pugi::xml_node> out;
  for (pugi::xml_node child : node.children()) {
    if (child.type() != pugi::node_element) {
      // A text node starts right after the previous tag: place it at its first visible character.
      std::string text = child.value();
      size_t skip = std::min(text.find_first_not_of(" \t\r\n"), text.size());
      throw InputError(current().name + ":" + std::to_string(current().line_of(child.offset_debug() + skip)),
                       "unexpected text inside <" + std::string(node.name()) + ">");
    }
    out.push_back(child);
  }
  return out;
}

namespace {

std::string trim(const std::string& s) {
  size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

}  // namespace

float Context::parse_float(const pugi::xml_node& node, const std::string& text, const std::string& what) const {
  std::string t = trim(text);
  const char* begin = t.c_str();
  char* end = nullptr;
  double v = std::strtod(begin, &end);
  if (t.empty() || end != begin + t.size()) fail(node, "malformed number '" + text + "' in " + what);
  if (!std::isfinite(v) || !std::isfinite(static_cast<float>(v)))
    fail(node, "non-finite number '" + text + "' in " + what);
  return static_cast<float>(v);
}

int Context::parse_int(const pugi::xml_node& node, const std::string& text, const std::string& what) const {
  std::string t = trim(text);
  const char* begin = t.c_str();
  char* end = nullptr;
  errno = 0;
  long v = std::strtol(begin, &end, 10);
  if (t.empty() || end != begin + t.size()) fail(node, "malformed integer '" + text + "' in " + what);
  if (errno == ERANGE || v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    fail(node, "integer '" + text + "' out of range in " + what);
  return static_cast<int>(v);
}

bool Context::parse_bool(const pugi::xml_node& node, const std::string& text, const std::string& what) const {
  std::string t = trim(text);
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "true") return true;
  if (t == "false") return false;
  fail(node, "malformed boolean '" + text + "' in " + what + " (true or false)");
}

std::vector<float> Context::parse_floats(const pugi::xml_node& node, const std::string& text,
                                         const std::string& what) const {
  std::vector<float> out;
  size_t i = 0;
  while (i < text.size()) {
    size_t b = text.find_first_not_of(", \t\r\n", i);
    if (b == std::string::npos) break;
    size_t e = text.find_first_of(", \t\r\n", b);
    if (e == std::string::npos) e = text.size();
    out.push_back(parse_float(node, text.substr(b, e - b), what));
    i = e;
  }
  return out;
}

glm::vec3 Context::parse_triple(const pugi::xml_node& node, const std::string& text, const std::string& what) const {
  std::vector<float> v = parse_floats(node, text, what);
  if (v.size() == 1) return glm::vec3(v[0]);
  if (v.size() == 3) return glm::vec3(v[0], v[1], v[2]);
  fail(node, what + " needs 1 or 3 numbers, got " + std::to_string(v.size()));
}

glm::vec3 Context::parse_xyz(const pugi::xml_node& node, float fallback, const std::string& what) const {
  if (std::optional<std::string> value = opt_attr(node, "value")) {
    if (node.attribute("x") || node.attribute("y") || node.attribute("z"))
      fail(node, what + " mixes 'value' with 'x'/'y'/'z'");
    return parse_triple(node, *value, what);
  }
  glm::vec3 v(fallback);
  const char* axes[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    if (std::optional<std::string> a = opt_attr(node, axes[i]))
      v[i] = parse_float(node, *a, "'" + std::string(axes[i]) + "' of " + what);
  }
  return v;
}

}  // namespace spm::xml
