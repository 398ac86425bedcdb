// The children of one plugin element (<bsdf type="diffuse">...): its named
// properties and its nested objects.
#pragma once

#include <glm/glm.hpp>
#include <initializer_list>
#include <optional>
#include <pugixml.hpp>
#include <string>
#include <vector>

#include "scene/xml_context.h"

namespace spm::xml {

// Properties are checked off as the plugin reads them; finish() refuses any
// that were never read, as Mitsuba refuses unqueried properties, so a typo or
// an unsupported parameter cannot be skipped silently.
class Props {
 public:
  // `what` names the plugin in messages, e.g. "bsdf 'diffuse'".
  Props(const Context& ctx, const pugi::xml_node& element, std::string what);

  std::optional<float> get_float(const char* name);  // <float> or <integer>
  std::optional<int> get_int(const char* name);
  std::optional<bool> get_bool(const char* name);
  std::optional<std::string> get_string(const char* name);
  // <rgb>, <spectrum> with a single value (gray), or <float> (gray).
  std::optional<glm::vec3> get_color(const char* name);
  std::optional<glm::vec3> get_point(const char* name);  // <point> or <vector>
  std::optional<glm::mat4> get_transform(const char* name);

  // Element of a property that was read, to place messages about its value.
  [[noreturn]] void fail(const char* name, const std::string& problem) const;
  bool has(const char* name) const;
  bool is_tag(const char* name, const char* tag) const;  // given, as <tag>

  // Nested objects (<bsdf>, <medium>, <ref>, ...) in document order; the
  // plugin decides which it accepts.
  const std::vector<pugi::xml_node>& objects() const { return objects_; }
  const std::string& what() const { return what_; }

  // Refuses the first property no get_* call asked for.
  void finish() const;

 private:
  struct Prop {
    std::string name;
    pugi::xml_node node;
    bool used = false;
  };
  // Marks the property read and checks its tag is one of `tags`; null if absent.
  const Prop* take(const char* name, std::initializer_list<const char*> tags, const char* expected);
  std::string describe(const Prop& p) const;

  const Context& ctx_;
  std::string what_;
  std::vector<Prop> props_;
  std::vector<pugi::xml_node> objects_;
};

}  // namespace spm::xml
