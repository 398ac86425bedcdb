// State shared by the pieces of one scene load: the XML files being read (the
// scene and its includes), the $-parameters, and strict parsing of attribute
// values. Every failure is an InputError naming "file:line" of the element.
#pragma once

#include <glm/glm.hpp>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <pugixml.hpp>
#include <string>
#include <vector>

namespace spm::xml {

// Reads a whole file; `what` names it in messages ("scene file", "OBJ file").
std::string read_text_file(const std::string& path, const std::string& where, const std::string& what);

class Context {
 public:
  explicit Context(std::map<std::string, std::string> overrides);

  // Parses `text` as the XML file `name` and makes it the current source until
  // pop_source(); returns its <scene> root, version checked.
  pugi::xml_node push_source(const std::string& text, const std::string& name);
  void pop_source();
  // A file name resolved as Mitsuba 3 (3.9) resolves a plugin's file: an
  // absolute name as it is; a relative one against each folder of the search
  // path in turn (the <path> folders, latest first, then the top-level scene
  // file's folder, then the working directory), the first that exists. Not
  // against an included file's folder: Mitsuba resolves plugin files after
  // parsing, with the search path alone. When none exists: against the scene
  // file's folder, for the caller's message.
  std::string resolve(const std::string& name) const;
  // An <include>'s file: the including file's folder first, then the search
  // path, as Mitsuba 3.9's parser does.
  std::string resolve_include(const std::string& name) const;
  // <path value=".."/>: puts a folder first in the search path. A relative
  // value is taken from the current file's folder, or else resolved.
  void add_search_path(const pugi::xml_node& node);
  bool is_open(const std::string& name) const;  // include cycles

  std::string where(const pugi::xml_node& node) const;
  [[noreturn]] void fail(const pugi::xml_node& node, const std::string& problem) const;

  // <default name=".." value=".."/>: the first definition wins and a command
  // line override wins over all, as in Mitsuba.
  void define_default(const pugi::xml_node& node);
  // Every override must name a <default>; the CLI's -D cannot invent parameters.
  void check_overrides(const pugi::xml_node& root) const;

  // Attribute values, $-substituted. attr() requires the attribute.
  std::string attr(const pugi::xml_node& node, const char* name) const;
  std::optional<std::string> opt_attr(const pugi::xml_node& node, const char* name) const;
  // Refuses attributes outside `allowed` (Mitsuba does too).
  void check_attributes(const pugi::xml_node& node, std::initializer_list<const char*> allowed) const;
  // Element children only; text inside an element is refused.
  std::vector<pugi::xml_node> elements(const pugi::xml_node& node) const;

  // Strict conversions: the whole string must be the value, and floats must be
  // finite. `what` names the value in messages, e.g. "value of <float name='fov'>".
  float parse_float(const pugi::xml_node& node, const std::string& text, const std::string& what) const;
  int parse_int(const pugi::xml_node& node, const std::string& text, const std::string& what) const;
  bool parse_bool(const pugi::xml_node& node, const std::string& text, const std::string& what) const;
  // Numbers separated by commas and/or whitespace.
  std::vector<float> parse_floats(const pugi::xml_node& node, const std::string& text, const std::string& what) const;
  // One number (filling x, y and z) or three.
  glm::vec3 parse_triple(const pugi::xml_node& node, const std::string& text, const std::string& what) const;
  // A vector given as value="a" / value="x, y, z", or as separate x, y, z
  // attributes, each defaulting to `fallback` (<point>, <translate>, ...).
  glm::vec3 parse_xyz(const pugi::xml_node& node, float fallback, const std::string& what) const;

 private:
  struct Source {
    std::string name;
    std::string dir;
    pugi::xml_document doc;
    std::vector<size_t> line_starts;  // byte offset of each line, for offset -> line
    int line_of(ptrdiff_t offset) const;
  };

  std::string substitute(const pugi::xml_node& node, const char* attribute, const std::string& raw) const;
  const Source& current() const { return *sources_.back(); }

  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<std::string> search_path_;  // first match wins
  std::map<std::string, std::string> overrides_;
  std::map<std::string, std::string> defaults_;
};

}  // namespace spm::xml
