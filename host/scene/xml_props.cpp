#include "scene/xml_props.h"

#include <algorithm>
#include <cstring>
#include <iterator>

#include "scene/xml_transform.h"

namespace spm::xml {

namespace {

template <typename Tags>
bool one_of(const std::string& tag, const Tags& tags) {
  return std::any_of(std::begin(tags), std::end(tags), [&](const char* t) { return tag == t; });
}

constexpr const char* kPropertyTags[] = {"float",    "integer", "boolean", "string",   "rgb",
                                         "spectrum", "point",   "vector",  "transform"};
constexpr const char* kObjectTags[] = {"sensor",  "film",   "rfilter", "sampler",    "shape", "bsdf",
                                       "emitter", "medium", "phase",   "integrator", "ref",
                                       "volume"};

// A property element holds its value in attributes; anything inside it
// (elements or text) would otherwise be skipped silently.
void no_content(const Context& ctx, const pugi::xml_node& node) {
  pugi::xml_node child = node.first_child();
  if (child)
    ctx.fail(child.type() == pugi::node_element ? child : node,
             "<" + std::string(node.name()) + "> takes no content (its value goes in attributes)");
}

}  // namespace

Props::Props(const Context& ctx, const pugi::xml_node& element, std::string what) : ctx_(ctx), what_(std::move(what)) {
  for (const pugi::xml_node& child : ctx.elements(element)) {
    std::string tag = child.name();
    if (one_of(tag, kPropertyTags)) {
      std::string name = ctx.attr(child, "name");
      auto same = [&](const Prop& p) { return p.name == name; };
      if (std::any_of(props_.begin(), props_.end(), same))
        ctx.fail(child, "property '" + name + "' of " + what_ + " is given twice");
      props_.push_back({name, child});
    } else if (one_of(tag, kObjectTags)) {
      objects_.push_back(child);
    } else {
      ctx.fail(child, "unknown or unsupported tag <" + tag + "> in " + what_);
    }
  }
}

std::string Props::describe(const Prop& p) const { return "property '" + p.name + "' of " + what_; }

const Props::Prop* Props::take(const char* name, std::initializer_list<const char*> tags, const char* expected) {
  for (Prop& p : props_) {
    if (p.name != name) continue;
    p.used = true;
    if (!one_of(p.node.name(), tags))
      ctx_.fail(p.node, describe(p) + " must be " + expected + ", not <" + p.node.name() + ">");
    if (std::string(p.node.name()) != "transform") no_content(ctx_, p.node);
    return &p;
  }
  return nullptr;
}

bool Props::has(const char* name) const {
  return std::any_of(props_.begin(), props_.end(), [&](const Prop& p) { return p.name == name; });
}

bool Props::is_tag(const char* name, const char* tag) const {
  return std::any_of(props_.begin(), props_.end(),
                     [&](const Prop& p) { return p.name == name && std::strcmp(p.node.name(), tag) == 0; });
}

void Props::fail(const char* name, const std::string& problem) const {
  for (const Prop& p : props_)
    if (p.name == name) ctx_.fail(p.node, problem);
  throw std::logic_error("Props::fail on a property that was not given: " + std::string(name));
}

std::optional<float> Props::get_float(const char* name) {
  const Prop* p = take(name, {"float", "integer"}, "a <float>");
  if (!p) return std::nullopt;
  ctx_.check_attributes(p->node, {"name", "value"});
  return ctx_.parse_float(p->node, ctx_.attr(p->node, "value"), describe(*p));
}

std::optional<int> Props::get_int(const char* name) {
  const Prop* p = take(name, {"integer"}, "an <integer>");
  if (!p) return std::nullopt;
  ctx_.check_attributes(p->node, {"name", "value"});
  return ctx_.parse_int(p->node, ctx_.attr(p->node, "value"), describe(*p));
}

std::optional<bool> Props::get_bool(const char* name) {
  const Prop* p = take(name, {"boolean"}, "a <boolean>");
  if (!p) return std::nullopt;
  ctx_.check_attributes(p->node, {"name", "value"});
  return ctx_.parse_bool(p->node, ctx_.attr(p->node, "value"), describe(*p));
}

std::optional<std::string> Props::get_string(const char* name) {
  const Prop* p = take(name, {"string"}, "a <string>");
  if (!p) return std::nullopt;
  ctx_.check_attributes(p->node, {"name", "value"});
  return ctx_.attr(p->node, "value");
}

std::optional<glm::vec3> Props::get_color(const char* name) {
  const Prop* p = take(name, {"rgb", "spectrum", "float", "integer"}, "an <rgb>, <spectrum> or <float>");
  if (!p) return std::nullopt;
  std::string tag = p->node.name();
  if (tag == "spectrum" && (p->node.attribute("filename") || !p->node.attribute("value")))
    ctx_.fail(p->node, describe(*p) + ": only <spectrum value=\"x\"> (a gray value) is supported");
  ctx_.check_attributes(p->node, {"name", "value"});
  std::string value = ctx_.attr(p->node, "value");
  if (tag == "rgb") return ctx_.parse_triple(p->node, value, describe(*p));
  if (tag == "spectrum" && value.find_first_of(":,") != std::string::npos)
    ctx_.fail(p->node,
              describe(*p) + ": only <spectrum value=\"x\"> (a gray value) is supported, not wavelength:value pairs");
  return glm::vec3(ctx_.parse_float(p->node, value, describe(*p)));
}

std::optional<glm::vec3> Props::get_point(const char* name) {
  const Prop* p = take(name, {"point", "vector"}, "a <point>");
  if (!p) return std::nullopt;
  ctx_.check_attributes(p->node, {"name", "value", "x", "y", "z"});
  return ctx_.parse_xyz(p->node, 0.0f, describe(*p));
}

std::optional<glm::mat4> Props::get_transform(const char* name) {
  const Prop* p = take(name, {"transform"}, "a <transform>");
  if (!p) return std::nullopt;
  return parse_transform(ctx_, p->node);
}

void Props::finish() const {
  for (const Prop& p : props_)
    if (!p.used) ctx_.fail(p.node, "unknown property '" + p.name + "' of " + what_);
}

}  // namespace spm::xml
