// The plugins of the SCENES.md subset, read into a plain spm::Scene.
#include "scene/loader.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <iostream>
#include <set>
#include <utility>

#include "film/image_io.h"
#include "scene/settings.h"
#include "scene/conductors.h"
#include "scene/light_power.h"
#include "scene/media_regions.h"
#include "scene/mesh.h"
#include "scene/obj.h"
#include "scene/ply.h"
#include "scene/serialized.h"
#include "scene/xml_context.h"
#include "scene/xml_props.h"
#include "scene/xml_transform.h"
#include "util/errors.h"

namespace spm {

namespace {

using xml::Props;

bool non_negative(const glm::vec3& c) { return glm::all(glm::greaterThanEqual(c, glm::vec3(0.0f))); }
bool in_unit_range(const glm::vec3& c) { return non_negative(c) && glm::all(glm::lessThanEqual(c, glm::vec3(1.0f))); }

// Mitsuba's named indices of refraction (its ior.h table).
const std::pair<const char*, float> kNamedIor[] = {
    {"vacuum", 1.0f},      {"helium", 1.00004f},         {"hydrogen", 1.00013f},
    {"air", 1.000277f},    {"carbon dioxide", 1.00045f}, {"water", 1.3330f},
    {"acetone", 1.36f},    {"ethanol", 1.361f},          {"carbon tetrachloride", 1.461f},
    {"glycerol", 1.4729f}, {"benzene", 1.501f},          {"silicone oil", 1.52045f},
    {"bromine", 1.661f},   {"water ice", 1.31f},         {"fused quartz", 1.458f},
    {"pyrex", 1.470f},     {"acrylic glass", 1.49f},     {"polypropylene", 1.49f},
    {"bk7", 1.5046f},      {"sodium chloride", 1.544f},  {"amber", 1.55f},
    {"pet", 1.5750f},      {"diamond", 2.419f},
};

class Loader {
 public:
  explicit Loader(const std::map<std::string, std::string>& overrides) : ctx_(overrides) {}

  Scene load(const std::string& xml, const std::string& name) {
    scene_.path = name;
    pugi::xml_node root = ctx_.push_source(xml, name);
    parse_children(root);
    ctx_.check_overrides(root);
    if (scene_.lights.empty()) ctx_.fail(root, "scene has no light (no emitter)");
    for (const Light& light : scene_.lights) check_power(light);
    resolve_light_media(scene_);
    return std::move(scene_);
  }

 private:
  // What an id names, so that a ref can be checked for the right kind.
  struct Named {
    std::string tag;  // element name: "bsdf", "medium", "shape", ...
    int index = -1;   // into Scene::materials / media for bsdf and medium
    std::string where;
  };

  void parse_children(const pugi::xml_node& scene) {
    for (const pugi::xml_node& node : ctx_.elements(scene)) {
      std::string tag = node.name();
      if (tag == "default")
        ctx_.define_default(node);
      else if (tag == "include")
        parse_include(node);
      else if (tag == "path") {
        no_content(node);
        ctx_.add_search_path(node);
      }
      else if (tag == "sensor")
        parse_sensor(node);
      else if (tag == "shape")
        parse_shape(node);
      else if (tag == "bsdf")
        add_bsdf(node);
      else if (tag == "medium")
        add_medium(node);
      else if (tag == "emitter")
        parse_emitter(node);
      else if (tag == "integrator")
        parse_integrator(node);
      else
        ctx_.fail(node, "unknown or unsupported tag <" + tag + "> in <scene>");
    }
  }

  // The children of an included <scene> are read as if they were written
  // here. Its name is resolved against the including file's folder, then the
  // search path; the file names inside it by the search path alone.
  void parse_include(const pugi::xml_node& node) {
    ctx_.check_attributes(node, {"filename"});
    no_content(node);
    std::string path = ctx_.resolve_include(ctx_.attr(node, "filename"));
    if (ctx_.is_open(path)) ctx_.fail(node, "<include> of '" + path + "' includes itself");
    std::string text = xml::read_text_file(path, ctx_.where(node), "included file");
    pugi::xml_node root = ctx_.push_source(text, path);
    parse_children(root);
    ctx_.pop_source();
  }

  // <include> and <ref> are empty elements: content would be skipped silently.
  void no_content(const pugi::xml_node& node) const {
    if (pugi::xml_node child = node.first_child())
      ctx_.fail(child.type() == pugi::node_element ? child : node,
                "<" + std::string(node.name()) + "> takes no content");
  }

  // Checks the attributes every plugin element may have and returns its type.
  std::string object_type(const pugi::xml_node& node) {
    ctx_.check_attributes(node, {"type", "id", "name"});
    return ctx_.attr(node, "type");
  }

  void register_id(const pugi::xml_node& node, int index) {
    std::optional<std::string> id = ctx_.opt_attr(node, "id");
    if (!id) return;
    if (id->empty()) ctx_.fail(node, "empty id");
    if (ids_.count(*id)) ctx_.fail(node, "duplicate id '" + *id + "' (first used at " + ids_[*id].where + ")");
    ids_[*id] = {node.name(), index, ctx_.where(node)};
  }

  // <ref id=".."/>: the index of the earlier object it names, which must be a `tag`.
  int resolve_ref(const pugi::xml_node& ref, const std::string& tag) {
    ctx_.check_attributes(ref, {"id", "name"});
    no_content(ref);
    std::string id = ctx_.attr(ref, "id");
    auto it = ids_.find(id);
    if (it == ids_.end()) ctx_.fail(ref, "<ref> to unknown id '" + id + "' (ids must be defined before use)");
    if (it->second.tag != tag)
      ctx_.fail(ref, "<ref id=\"" + id + "\"> names a " + it->second.tag + " where a " + tag + " is expected");
    return it->second.index;
  }

  // The kind a <ref> points at, to dispatch refs whose role depends on it.
  std::string ref_tag(const pugi::xml_node& ref) {
    auto it = ids_.find(ctx_.attr(ref, "id"));
    return it == ids_.end() ? "" : it->second.tag;
  }

  // ---- sensor -------------------------------------------------------------

  void parse_sensor(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (have_sensor_) ctx_.fail(node, "a second <sensor> (only one per scene)");
    have_sensor_ = true;
    if (type != "perspective") ctx_.fail(node, "unsupported sensor type '" + type + "' (perspective)");
    Props p(ctx_, node, "sensor '" + type + "'");
    Camera& cam = scene_.camera;
    cam.where = ctx_.where(node);
    if (std::optional<float> fov = p.get_float("fov")) {
      if (!(*fov > 0.0f && *fov < 180.0f)) p.fail("fov", "fov must be in (0, 180) degrees");
      cam.fov = *fov;
    }
    if (std::optional<std::string> axis = p.get_string("fov_axis")) {
      const std::pair<const char*, Camera::FovAxis> axes[] = {{"x", Camera::FovAxis::X},
                                                              {"y", Camera::FovAxis::Y},
                                                              {"smaller", Camera::FovAxis::Smaller},
                                                              {"larger", Camera::FovAxis::Larger},
                                                              {"diagonal", Camera::FovAxis::Diagonal}};
      bool found = false;
      for (const auto& [n, a] : axes)
        if (*axis == n) cam.fov_axis = a, found = true;
      if (!found) p.fail("fov_axis", "unknown fov_axis '" + *axis + "' (x, y, smaller, larger, diagonal)");
    }
    if (std::optional<glm::mat4> m = p.get_transform("to_world")) {
      if (!xml::is_invertible(*m)) p.fail("to_world", "singular to_world of the sensor");
      cam.to_world = *m;
    }
    if (std::optional<float> v = p.get_float("near_clip")) {
      if (!(*v > 0.0f)) p.fail("near_clip", "near_clip must be positive");
      cam.near_clip = *v;
    }
    if (std::optional<float> v = p.get_float("far_clip")) cam.far_clip = *v;
    if (!(cam.far_clip > cam.near_clip))
      p.fail(p.has("far_clip") ? "far_clip" : "near_clip", "far_clip must be larger than near_clip");
    p.finish();

    bool have_film = false, have_sampler = false;
    for (const pugi::xml_node& child : p.objects()) {
      std::string tag = child.name();
      if (tag == "film") {
        if (have_film) ctx_.fail(child, "a second <film> in the sensor");
        have_film = true;
        parse_film(child);
      } else if (tag == "sampler") {
        if (have_sampler) ctx_.fail(child, "a second <sampler> in the sensor");
        have_sampler = true;
        parse_sampler(child);
      } else if (tag == "medium" || tag == "ref") {
        set_medium(cam.medium, child, "the sensor");
      } else {
        ctx_.fail(child, "<" + tag + "> is not allowed in " + p.what());
      }
    }
    register_id(node, -1);
  }

  // The medium an endpoint (sensor, point or spot light) sits in.
  void set_medium(int& medium, const pugi::xml_node& child, const std::string& owner) {
    if (medium >= 0) ctx_.fail(child, "a second medium for " + owner);
    medium = std::string(child.name()) == "ref" ? resolve_ref(child, "medium") : add_medium(child);
  }

  void parse_film(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type != "hdrfilm") ctx_.fail(node, "unsupported film type '" + type + "' (hdrfilm)");
    Props p(ctx_, node, "film '" + type + "'");
    Camera& cam = scene_.camera;
    auto read_size = [&](const char* name, int& field) {
      if (std::optional<int> v = p.get_int(name)) {
        if (*v < 1 || *v > 16384) p.fail(name, std::string(name) + " must be in [1, 16384]");
        field = *v;
      }
    };
    read_size("width", cam.width);
    read_size("height", cam.height);
    // Output formats are the film writer's business; accepted so that the
    // file stays valid for Mitsuba.
    p.get_string("pixel_format");
    p.get_string("component_format");
    p.finish();
    bool have_filter = false;
    for (const pugi::xml_node& child : p.objects()) {
      if (std::string(child.name()) != "rfilter")
        ctx_.fail(child, "<" + std::string(child.name()) + "> is not allowed in " + p.what());
      if (have_filter) ctx_.fail(child, "a second <rfilter> in the film");
      have_filter = true;
      parse_rfilter(child);
    }
    register_id(node, -1);
  }

  void parse_rfilter(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type != "box" && type != "gaussian") ctx_.fail(node, "unsupported rfilter type '" + type + "' (box, gaussian)");
    Props p(ctx_, node, "rfilter '" + type + "'");
    Camera& cam = scene_.camera;
    if (type == "box") {
      cam.filter = Camera::Filter::Box;
    } else {
      cam.filter = Camera::Filter::Gaussian;
      if (std::optional<float> s = p.get_float("stddev")) {
        if (!(*s > 0.0f)) p.fail("stddev", "stddev must be positive");
        cam.filter_stddev = *s;
      }
    }
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  void parse_sampler(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type != "independent") ctx_.fail(node, "unsupported sampler type '" + type + "' (independent)");
    Props p(ctx_, node, "sampler '" + type + "'");
    if (std::optional<int> n = p.get_int("sample_count")) {
      if (*n < 1) p.fail("sample_count", "sample_count must be at least 1");
      scene_.camera.spp = *n;
    }
    // The renderer seeds its counter-based RNG itself (METHOD.md section 7).
    p.get_int("seed");
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  void no_objects(const Props& p) {
    if (!p.objects().empty())
      ctx_.fail(p.objects().front(), "<" + std::string(p.objects().front().name()) + "> is not allowed in " + p.what());
  }

  // ---- shapes -------------------------------------------------------------

  void parse_shape(const pugi::xml_node& node) {
    std::string type = object_type(node);
    static const std::set<std::string> kShapes = {"rectangle", "cube", "sphere", "disk", "cylinder",
                                                  "obj", "ply", "serialized"};
    if (!kShapes.count(type))
      ctx_.fail(node, "unsupported shape type '" + type +
                          "' (rectangle, cube, sphere, disk, cylinder, obj, ply, serialized)");
    Props p(ctx_, node, "shape '" + type + "'");
    Shape shape;
    shape.where = ctx_.where(node);
    glm::mat4 to_world = p.get_transform("to_world").value_or(glm::mat4(1.0f));
    if (!xml::is_invertible(to_world)) {
      glm::mat3 l(to_world);
      if (type == "rectangle" && !(glm::length(glm::cross(l[0], l[1])) > 0.0f))
        p.fail("to_world", "to_world of " + p.what() + " gives it zero area (an axis scaled to zero)");
      p.fail("to_world", "singular to_world of " + p.what() + " (an axis scaled to zero, or two axes parallel)");
    }
    shape.flip_normals = p.get_bool("flip_normals").value_or(false);

    if (type == "sphere") {
      build_sphere(shape, p, to_world);
    } else if (type == "rectangle" || type == "disk") {
      build_flat(shape, p, to_world, type == "disk" ? disk_mesh() : rectangle_mesh());
    } else if (type == "cube") {
      to_world_mesh(shape, cube_mesh(), to_world);
    } else if (type == "cylinder") {
      to_world_mesh(shape, cylinder_mesh(p), to_world);
    } else {
      std::optional<std::string> filename = p.get_string("filename");
      if (!filename) ctx_.fail(node, p.what() + " needs a 'filename' property");
      bool vertex_normals = !p.get_bool("face_normals").value_or(false);
      std::string path = ctx_.resolve(*filename);
      Mesh mesh;
      if (type == "obj") {
        mesh = parse_obj(xml::read_text_file(path, shape.where, "OBJ file"), path, vertex_normals, shape.where);
      } else if (type == "ply") {
        mesh = parse_ply(xml::read_text_file(path, shape.where, "PLY file"), path, vertex_normals, shape.where);
      } else {
        int index = p.get_int("shape_index").value_or(0);
        mesh = parse_serialized(xml::read_text_file(path, shape.where, "serialized mesh file"), path, index,
                                vertex_normals, shape.where);
      }
      // Mitsuba gives a mesh without normals smooth ones, unless face_normals.
      to_world_mesh(shape, std::move(mesh), to_world, vertex_normals);
    }
    p.finish();

    std::optional<Light> light;
    for (const pugi::xml_node& child : p.objects()) {
      std::string tag = child.name();
      std::string role = ctx_.opt_attr(child, "name").value_or("");
      bool medium_role = role == "interior" || role == "exterior";
      if (tag == "bsdf" || (tag == "ref" && !medium_role && ref_tag(child) != "medium")) {
        if (shape.material >= 0) ctx_.fail(child, "a second bsdf for " + p.what());
        shape.material = tag == "ref" ? resolve_ref(child, "bsdf") : add_bsdf(child);
      } else if (tag == "medium" || tag == "ref") {
        if (!medium_role) ctx_.fail(child, "a medium in a shape needs name=\"interior\" or name=\"exterior\"");
        int& slot = role == "interior" ? shape.interior : shape.exterior;
        if (slot >= 0) ctx_.fail(child, "a second " + role + " medium for " + p.what());
        slot = tag == "ref" ? resolve_ref(child, "medium") : add_medium(child);
      } else if (tag == "emitter") {
        if (light) ctx_.fail(child, "a second emitter for " + p.what());
        light = read_area_emitter(child);
      } else {
        ctx_.fail(child, "<" + tag + "> is not allowed in " + p.what());
      }
    }
    if (shape.material < 0) {
      // Mitsuba gives a shape without bsdf a diffuse 0.5 one, and an emitter
      // shape a black one (its Shape constructor sets reflectance 0).
      Material fallback;
      if (light) fallback.reflectance = glm::vec3(0.0f);
      fallback.where = shape.where;
      shape.material = static_cast<int>(scene_.materials.size());
      scene_.materials.push_back(fallback);
    }
    int index = static_cast<int>(scene_.shapes.size());
    if (light) {
      light->shape = index;
      // A medium-transition shape says what its outside is, vacuum
      // included; any other shape's light sits in its region's medium.
      light->medium = shape.exterior;
      light->medium_given = shape.interior >= 0 || shape.exterior >= 0;
      shape.light = static_cast<int>(scene_.lights.size());
      scene_.lights.push_back(*light);
    }
    scene_.shapes.push_back(std::move(shape));
    register_id(node, index);
  }

  // Mitsuba's sphere: `center` and `radius`, then to_world, which may only
  // rotate, translate and scale uniformly since the shape stays a sphere.
  void build_sphere(Shape& shape, Props& p, const glm::mat4& to_world) {
    shape.kind = Shape::Kind::Sphere;
    glm::vec3 center = p.get_point("center").value_or(glm::vec3(0.0f));
    float radius = p.get_float("radius").value_or(1.0f);
    if (!(radius > 0.0f)) p.fail("radius", "sphere radius must be positive");
    glm::mat3 l(to_world);
    glm::mat3 gram = glm::transpose(l) * l;
    float s2 = (gram[0][0] + gram[1][1] + gram[2][2]) / 3.0f;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r)
        if (std::abs(gram[c][r] - (c == r ? s2 : 0.0f)) > 1e-4f * s2)
          p.fail("to_world", "to_world of a sphere must scale uniformly (no non-uniform scale or shear)");
    shape.center = glm::vec3(to_world * glm::vec4(center, 1.0f));
    shape.radius = radius * std::sqrt(s2);
  }

  // Mitsuba's rectangle and disk are analytic with normal to_world(+z)
  // transformed as a normal, whatever the handedness of to_world; meshes
  // (cube, obj) instead keep their winding. So a mirroring to_world flips the
  // flat shapes' winding.
  void build_flat(Shape& shape, Props& p, const glm::mat4& to_world, Mesh mesh) {
    glm::mat3 l(to_world);
    glm::vec3 du = glm::normalize(l[0]), dv = glm::normalize(l[1]);
    if (std::abs(glm::dot(du, dv)) > 1e-4f)
      p.fail("to_world", "to_world of a " + p.what() + " contains shear (Mitsuba refuses it too)");
    if (glm::determinant(l) < 0.0f)
      for (glm::uvec3& t : mesh.triangles) std::swap(t.y, t.z);
    to_world_mesh(shape, std::move(mesh), to_world);
  }

  // [-1,1]^2 in the XY plane, normal +z.
  static Mesh rectangle_mesh() {
    Mesh mesh;
    mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    mesh.triangles = {{0, 1, 2}, {2, 3, 0}};
    return mesh;
  }

  // Mitsuba's disk and cylinder are analytic; spm makes them meshes of
  // kRoundSegments sides. The polygon's area is short of the circle's by
  // (2 pi / n)^2 / 6 = 2.5e-5 of it, and its outline lies within 1 - cos(pi / n)
  // = 1.9e-5 radii of the circle: below what a render can see.
  static constexpr unsigned kRoundSegments = 512;

  // The unit disk in the XY plane, normal +z: a fan around its centre.
  static Mesh disk_mesh() {
    Mesh mesh;
    mesh.positions.push_back({0, 0, 0});
    for (unsigned i = 0; i < kRoundSegments; ++i) {
      const double phi = 2.0 * M_PI * i / kRoundSegments;
      mesh.positions.push_back({float(std::cos(phi)), float(std::sin(phi)), 0.0f});
      mesh.triangles.push_back({0, 1 + i, 1 + (i + 1) % kRoundSegments});
    }
    return mesh;
  }

  // Mitsuba's cylinder: the open tube of `radius` from p0 to p1 (default the
  // unit one along +z), normals outward; the vertex normals are the tube's.
  static Mesh cylinder_mesh(Props& p) {
    glm::vec3 p0 = p.get_point("p0").value_or(glm::vec3(0.0f));
    glm::vec3 p1 = p.get_point("p1").value_or(glm::vec3(0.0f, 0.0f, 1.0f));
    float radius = p.get_float("radius").value_or(1.0f);
    if (!(radius > 0.0f)) p.fail("radius", "cylinder radius must be positive");
    glm::vec3 axis = p1 - p0;
    if (!(glm::length(axis) > 0.0f)) p.fail("p1", "cylinder p0 and p1 are the same point");
    glm::vec3 w = glm::normalize(axis);
    glm::vec3 u = unit_perpendicular(w);
    glm::vec3 v = glm::cross(w, u);
    Mesh mesh;
    for (unsigned i = 0; i < kRoundSegments; ++i) {
      const double phi = 2.0 * M_PI * i / kRoundSegments;
      glm::vec3 n = float(std::cos(phi)) * u + float(std::sin(phi)) * v;
      mesh.positions.insert(mesh.positions.end(), {p0 + radius * n, p1 + radius * n});
      mesh.normals.insert(mesh.normals.end(), {n, n});
      const unsigned a = 2 * i, b = 2 * ((i + 1) % kRoundSegments);
      // Counter-clockwise seen from outside: cross(edge around, edge along) points out.
      mesh.triangles.push_back({a, b, b + 1});
      mesh.triangles.push_back({a, b + 1, a + 1});
    }
    return mesh;
  }

  // [-1,1]^3 with outward winding (cross(p1 - p0, p2 - p0) points out), flat.
  static Mesh cube_mesh() {
    Mesh mesh;
    for (int axis = 0; axis < 3; ++axis) {
      for (float side : {-1.0f, 1.0f}) {
        glm::vec3 n(0.0f), u(0.0f);
        n[axis] = side;
        u[(axis + 1) % 3] = 1.0f;
        glm::vec3 v = glm::cross(n, u);
        auto base = static_cast<unsigned>(mesh.positions.size());
        mesh.positions.insert(mesh.positions.end(), {n - u - v, n + u - v, n + u + v, n - u + v});
        mesh.triangles.push_back({base, base + 1, base + 2});
        mesh.triangles.push_back({base, base + 2, base + 3});
      }
    }
    return mesh;
  }

  // Positions by to_world, normals by its inverse transpose; then zero-area
  // triangles are dropped (they have no normal to shade or to orient media).
  // `smooth` gives a mesh without normals Mitsuba's smooth ones, from its
  // world-space triangles.
  void to_world_mesh(Shape& shape, Mesh mesh, const glm::mat4& to_world, bool smooth = false) {
    glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(to_world)));
    for (glm::vec3& pos : mesh.positions) {
      pos = glm::vec3(to_world * glm::vec4(pos, 1.0f));
      if (!std::isfinite(pos.x) || !std::isfinite(pos.y) || !std::isfinite(pos.z))
        throw InputError(shape.where, "a vertex position is not finite in world space");
    }
    for (glm::vec3& n : mesh.normals) {
      glm::vec3 w = normal_matrix * n;
      float len = glm::length(w);
      if (!(len > 0.0f) || !std::isfinite(len)) throw InputError(shape.where, "a vertex normal has zero length");
      n = w / len;
    }
    size_t dropped = 0;
    for (const glm::uvec3& t : mesh.triangles) {
      // In double: squared lengths of float positions underflow or overflow a
      // float for very small or very large meshes.
      glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
      double twice_area = glm::length(glm::cross(b - a, c - a));
      double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
      // Zero area up to float rounding: height over the longest edge ~ 0.
      if (!(twice_area > 1e-7 * longest * longest)) {
        ++dropped;
        continue;
      }
      shape.triangles.push_back(t);
    }
    if (shape.triangles.empty()) throw InputError(shape.where, "mesh has no triangles of non-zero area");
    if (smooth && mesh.normals.empty()) mesh.normals = angle_weighted_normals(mesh.positions, shape.triangles);
    if (dropped > 0)
      std::cerr << shape.where << ": warning: dropped " << dropped << " degenerate (zero-area) triangle"
                << (dropped == 1 ? "" : "s") << " of the shape\n";
    shape.positions = std::move(mesh.positions);
    shape.normals = std::move(mesh.normals);
  }

  // ---- light power ---------------------------------------------------------

  // A light the renderer cannot pick, with no power (zero radiance or
  // intensity, zero area) or more than a float holds, is refused here, at its
  // element, before anything is rendered. The power is the one lights are
  // picked by (scene/light_power.h, the mean over RGB), rounded to float.
  void check_power(const Light& light) const {
    const bool area = light.type == Light::Type::Area;
    const bool directional = light.type == Light::Type::Directional;
    const bool environment = light.type == Light::Type::Envmap;
    const char* what = area ? "radiance" : directional ? "irradiance" : environment ? "radiance (or map)" : "intensity";
    const glm::dvec3 emitted(light_emission(light));
    if (!((emitted.x + emitted.y + emitted.z) / 3.0 > 0.0)) {
      throw InputError(light.where, std::string("light emits no power: its ") + what + " is zero");
    }
    const double extent = light_extent(scene_, light);
    const glm::dvec3 rgb = light_power(scene_, light);
    const float power = static_cast<float>((rgb.x + rgb.y + rgb.z) / 3.0);
    if (!(extent > 0.0) || !(power > 0.0f)) {
      throw InputError(light.where, std::string("light emits no power: its ") +
                                        (area                                ? "area"
                                         : light.type == Light::Type::Spot   ? "cone (cutoff_angle)"
                                         : directional || environment        ? "scene (no shape to light)"
                                                                             : "extent") +
                                        " is zero or too small");
    }
    if (!std::isfinite(power))
      throw InputError(light.where, "light power overflows a 32-bit float: reduce its " + std::string(what) +
                                        (area ? " or its shape's size" : ""));
  }

  // ---- bsdfs --------------------------------------------------------------

  int add_bsdf(const pugi::xml_node& node) {
    Material m = read_bsdf(node);
    int index = static_cast<int>(scene_.materials.size());
    scene_.materials.push_back(m);
    register_id(node, index);
    return index;
  }

  Material read_bsdf(const pugi::xml_node& node) {
    std::string type = object_type(node);
    static const char* const kTypes[] = {"diffuse",         "conductor",       "roughconductor", "dielectric",
                                         "roughdielectric", "thindielectric", "plastic",        "null",
                                         "twosided"};
    if (std::find(std::begin(kTypes), std::end(kTypes), type) == std::end(kTypes))
      ctx_.fail(node, "unsupported bsdf type '" + type +
                          "' (diffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, "
                          "plastic, twosided, null)");
    Props p(ctx_, node, "bsdf '" + type + "'");
    Material m;
    m.where = ctx_.where(node);
    if (type == "diffuse") {
      m.type = Material::Type::Diffuse;
      m.reflectance = reflectance(p, "reflectance", m.reflectance);
    } else if (type == "conductor" || type == "roughconductor") {
      m.type = type == "conductor" ? Material::Type::Conductor : Material::Type::RoughConductor;
      read_conductor(p, m);
      if (m.type == Material::Type::RoughConductor) read_roughness(p, m);
    } else if (type == "dielectric" || type == "thindielectric" || type == "roughdielectric") {
      m.type = type == "dielectric"        ? Material::Type::Dielectric
               : type == "thindielectric" ? Material::Type::ThinDielectric
                                          : Material::Type::RoughDielectric;
      m.int_ior = ior(p, "int_ior", m.int_ior);
      m.ext_ior = ior(p, "ext_ior", m.ext_ior);
      if (m.type == Material::Type::RoughDielectric) read_roughness(p, m);
    } else if (type == "plastic") {
      m.type = Material::Type::Plastic;
      m.int_ior = ior(p, "int_ior", 1.49f);  // polypropylene
      m.ext_ior = ior(p, "ext_ior", m.ext_ior);
      m.reflectance = reflectance(p, "diffuse_reflectance", m.reflectance);
      m.specular = reflectance(p, "specular_reflectance", m.specular);
      m.nonlinear = p.get_bool("nonlinear").value_or(false);
    } else if (type == "null") {
      m.type = Material::Type::Null;
    } else {
      p.finish();
      return read_twosided(node, p);
    }
    p.finish();
    no_objects(p);
    return m;
  }

  // A reflectance in [0, 1] per channel.
  glm::vec3 reflectance(Props& p, const char* name, glm::vec3 fallback) {
    std::optional<glm::vec3> r = p.get_color(name);
    if (!r) return fallback;
    if (!in_unit_range(*r)) p.fail(name, std::string(name) + " must be in [0, 1]");
    return *r;
  }

  // A conductor's complex index: eta and k, or one of Mitsuba's named
  // materials (tools/conductor_iors.py), or "none", a perfect mirror.
  void read_conductor(Props& p, Material& m) {
    const bool given = p.has("eta") || p.has("k");
    std::string material = p.get_string("material").value_or("none");
    if (given) {
      if (material != "none") p.fail("material", "give either eta and k or a material, not both");
      m.eta = p.get_color("eta").value_or(glm::vec3(0.0f));
      m.k = p.get_color("k").value_or(glm::vec3(1.0f));
      if (!non_negative(m.eta) || !non_negative(m.k)) p.fail(p.has("eta") ? "eta" : "k", "eta and k must be >= 0");
    } else if (material != "none") {
      const auto it = std::find_if(std::begin(kNamedConductors), std::end(kNamedConductors),
                                   [&](const NamedConductor& c) { return material == c.name; });
      if (it == std::end(kNamedConductors)) p.fail("material", "unknown conductor material '" + material + "'");
      m.eta = glm::vec3(it->eta[0], it->eta[1], it->eta[2]);
      m.k = glm::vec3(it->k[0], it->k[1], it->k[2]);
    }
    m.specular = reflectance(p, "specular_reflectance", m.specular);
  }

  // A microfacet lobe's distribution and roughness. Mitsuba's anisotropic
  // roughness needs its tangent frames (uv parametrisation): refused
  // unless alpha_u equals alpha_v. sample_visible changes only how the
  // lobe is sampled (spm samples visible normals always), not the image.
  void read_roughness(Props& p, Material& m) {
    const std::string distribution = p.get_string("distribution").value_or("beckmann");
    if (distribution == "ggx") m.distribution = Material::Distribution::GGX;
    else if (distribution != "beckmann")
      p.fail("distribution", "unknown distribution '" + distribution + "' (beckmann, ggx)");
    if (p.has("alpha_u") || p.has("alpha_v")) {
      if (p.has("alpha")) p.fail("alpha", "give either alpha or alpha_u and alpha_v, not both");
      const std::optional<float> u = p.get_float("alpha_u"), v = p.get_float("alpha_v");
      if (!u || !v) p.fail(u ? "alpha_u" : "alpha_v", "alpha_u and alpha_v go together");
      if (*u != *v) p.fail("alpha_u", "anisotropic roughness (alpha_u != alpha_v) is not supported");
      m.alpha = *u;
    } else {
      m.alpha = p.get_float("alpha").value_or(m.alpha);
    }
    if (!(m.alpha >= 0.0f) || !std::isfinite(m.alpha)) p.fail("alpha", "alpha must be >= 0");
    p.get_bool("sample_visible");
  }

  // A float, or one of Mitsuba's named materials as a string.
  float ior(Props& p, const char* name, float fallback) {
    if (!p.has(name)) return fallback;
    float value = 0.0f;
    if (p.is_tag(name, "string")) {
      std::string named = *p.get_string(name);
      bool found = false;
      for (const auto& [n, v] : kNamedIor)
        if (named == n) value = v, found = true;
      if (!found) p.fail(name, "unknown " + std::string(name) + " material '" + named + "'");
    } else {
      value = *p.get_float(name);
    }
    if (!(value > 0.0f)) p.fail(name, std::string(name) + " must be positive");
    return value;
  }

  // twosided wraps exactly one bsdf; Mitsuba refuses transmissive ones in it.
  Material read_twosided(const pugi::xml_node& node, const Props& p) {
    if (p.objects().size() != 1) ctx_.fail(node, "bsdf 'twosided' needs exactly one nested bsdf");
    const pugi::xml_node& child = p.objects().front();
    std::string tag = child.name();
    Material inner;
    if (tag == "ref") {
      inner = scene_.materials[resolve_ref(child, "bsdf")];
    } else if (tag == "bsdf") {
      // Checked before reading it: twosided in twosided means nothing more,
      // and nesting it thousands deep would overflow the stack.
      if (ctx_.opt_attr(child, "type") == std::optional<std::string>("twosided"))
        ctx_.fail(child, "bsdf 'twosided' cannot wrap another twosided bsdf");
      inner = child.attribute("id") ? scene_.materials[add_bsdf(child)] : read_bsdf(child);
    } else {
      ctx_.fail(child, "<" + tag + "> is not allowed in bsdf 'twosided'");
    }
    if (inner.twosided) ctx_.fail(child, "bsdf 'twosided' cannot wrap another twosided bsdf");
    if (!inner.opaque())
      ctx_.fail(child,
                "bsdf 'twosided' cannot wrap a transmissive bsdf (dielectric, roughdielectric, thindielectric, null)");
    inner.twosided = true;
    inner.where = ctx_.where(node);
    return inner;
  }

  // ---- emitters -----------------------------------------------------------

  Light read_area_emitter(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type != "area") ctx_.fail(node, "emitter '" + type + "' cannot be nested in a shape (only 'area')");
    Props p(ctx_, node, "emitter 'area'");
    Light light;
    light.type = Light::Type::Area;
    light.where = ctx_.where(node);
    if (std::optional<glm::vec3> r = p.get_color("radiance")) {
      if (!non_negative(*r)) p.fail("radiance", "radiance must not be negative");
      light.radiance = *r;
    }
    p.finish();
    no_objects(p);
    register_id(node, -1);
    return light;
  }

  void parse_emitter(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type == "area") ctx_.fail(node, "an 'area' emitter must be nested in a <shape>");
    if (type == "directional") {
      parse_directional(node);
      return;
    }
    if (type == "constant" || type == "envmap") {
      parse_environment(node, type);
      return;
    }
    if (type != "point" && type != "spot")
      ctx_.fail(node, "unsupported emitter type '" + type +
                          "' (area in a shape, point, spot, directional, constant, envmap)");
    Props p(ctx_, node, "emitter '" + type + "'");
    Light light;
    light.where = ctx_.where(node);
    if (std::optional<glm::vec3> i = p.get_color("intensity")) {
      if (!non_negative(*i)) p.fail("intensity", "intensity must not be negative");
      light.intensity = *i;
    }
    std::optional<glm::mat4> to_world = p.get_transform("to_world");
    if (type == "point") {
      light.type = Light::Type::Point;
      if (std::optional<glm::vec3> pos = p.get_point("position")) {
        if (to_world) p.fail("position", "give either 'position' or 'to_world' of a point emitter, not both");
        to_world = glm::translate(glm::mat4(1.0f), *pos);
      }
    } else {
      light.type = Light::Type::Spot;
      if (to_world && !xml::is_invertible(*to_world)) p.fail("to_world", "singular to_world of " + p.what());
      if (std::optional<float> c = p.get_float("cutoff_angle")) {
        if (!(*c > 0.0f && *c < 180.0f)) p.fail("cutoff_angle", "cutoff_angle must be in (0, 180) degrees");
        light.cutoff_angle = *c;
      }
      light.beam_width = light.cutoff_angle * 0.75f;  // Mitsuba's default
      if (std::optional<float> b = p.get_float("beam_width")) {
        if (!(*b >= 0.0f && *b <= light.cutoff_angle))
          p.fail("beam_width", "beam_width must be in [0, cutoff_angle] degrees");
        light.beam_width = *b;
      }
    }
    p.finish();
    light.to_world = to_world.value_or(glm::mat4(1.0f));
    light.position = glm::vec3(light.to_world[3]);
    for (const pugi::xml_node& child : p.objects()) {
      std::string tag = child.name();
      if (tag != "medium" && tag != "ref") ctx_.fail(child, "<" + tag + "> is not allowed in " + p.what());
      set_medium(light.medium, child, p.what());
      light.medium_given = true;
    }
    scene_.lights.push_back(light);
    register_id(node, -1);
  }

  // Mitsuba's directional emitter: `irradiance` on a surface across its light,
  // travelling along `direction`, or along to_world's +z. It sits at
  // infinity, so it takes no medium: its light comes through whatever lies
  // outside the scene's shapes (METHOD.md 14).
  void parse_directional(const pugi::xml_node& node) {
    Props p(ctx_, node, "emitter 'directional'");
    Light light;
    light.type = Light::Type::Directional;
    light.where = ctx_.where(node);
    if (std::optional<glm::vec3> e = p.get_color("irradiance")) {
      if (!non_negative(*e)) p.fail("irradiance", "irradiance must not be negative");
      light.irradiance = *e;
    }
    std::optional<glm::mat4> to_world = p.get_transform("to_world");
    glm::vec3 direction = to_world ? glm::vec3(*to_world * glm::vec4(0.0f, 0.0f, 1.0f, 0.0f)) : glm::vec3(0, 0, 1);
    if (std::optional<glm::vec3> d = p.get_point("direction")) {
      if (to_world) p.fail("direction", "give either 'direction' or 'to_world' of a directional emitter, not both");
      direction = *d;
    }
    if (!(glm::length(direction) > 0.0f) || !std::isfinite(glm::length(direction)))
      p.fail(to_world ? "to_world" : "direction", "the direction of a directional emitter must be non-zero");
    light.direction = glm::normalize(direction);
    p.finish();
    no_objects(p);
    scene_.lights.push_back(light);
    register_id(node, -1);
  }

  // Mitsuba's constant emitter, `radiance` from every direction, and its
  // envmap, a lat-long image (OpenEXR, Radiance HDR, or an 8- or 16-bit
  // sRGB file such as PNG or JPEG) times `scale`, turned by to_world. Both
  // sit at infinity as a directional light does (METHOD.md 14); a constant
  // one is a map of one texel. Mitsuba reads an image of any shape as
  // lat-long; so does spm, with a warning when it is not 2:1.
  void parse_environment(const pugi::xml_node& node, const std::string& type) {
    Props p(ctx_, node, "emitter '" + type + "'");
    Light light;
    light.type = Light::Type::Envmap;
    light.where = ctx_.where(node);
    if (type == "constant") {
      glm::vec3 radiance(1.0f);
      if (std::optional<glm::vec3> r = p.get_color("radiance")) {
        if (!non_negative(*r)) p.fail("radiance", "radiance must not be negative");
        radiance = *r;
      }
      light.map = {radiance};
      light.map_width = light.map_height = 1;
    } else {
      std::optional<std::string> filename = p.get_string("filename");
      if (!filename) ctx_.fail(node, "emitter 'envmap' needs a filename");
      Image image;
      try {
        image = read_image(ctx_.resolve(*filename));
      } catch (const InputError& e) {
        p.fail("filename", e.what());
      }
      light.map_width = image.width;
      light.map_height = image.height;
      light.map.resize(size_t(image.width) * image.height);
      for (size_t k = 0; k < light.map.size(); ++k) {
        const glm::vec3 c(image.rgb[3 * k], image.rgb[3 * k + 1], image.rgb[3 * k + 2]);
        if (!non_negative(c) || !std::isfinite(c.x + c.y + c.z))
          p.fail("filename", *filename + ": pixel " + std::to_string(k % image.width) + ", " +
                                 std::to_string(k / image.width) + " is negative or not finite");
        light.map[k] = c;
      }
      if (image.width != 2 * image.height)
        std::cerr << light.where << ": warning: envmap " << *filename << " is " << image.width << " x "
                  << image.height << ", not 2:1; read as a lat-long map, as Mitsuba reads it\n";
      light.scale = p.get_float("scale").value_or(1.0f);
      if (!(light.scale >= 0.0f) || !std::isfinite(light.scale)) p.fail("scale", "scale must be >= 0");
    }
    if (std::optional<glm::mat4> to_world = p.get_transform("to_world")) {
      // Directions turn by its rotation (a uniform scale changes none); a
      // shear or an uneven scale would bend them, which Mitsuba's lookup
      // does not undo either.
      glm::mat3 r(*to_world);
      const float len = glm::length(r[0]);
      for (int c = 0; c < 3; ++c) {
        if (!(std::abs(glm::length(r[c]) - len) <= 1e-3f * len)) p.fail("to_world", "the to_world of an environment must be a rotation");
        r[c] = glm::normalize(r[c]);
      }
      const glm::mat3 rt = glm::transpose(r) * r;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          if (!(std::abs(rt[a][b] - (a == b ? 1.0f : 0.0f)) < 1e-3f))
            p.fail("to_world", "the to_world of an environment must be a rotation");
      light.frame = r;
    }
    p.finish();
    no_objects(p);
    scene_.lights.push_back(light);
    register_id(node, -1);
  }

  // ---- media --------------------------------------------------------------

  int add_medium(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (type != "homogeneous" && type != "heterogeneous")
      ctx_.fail(node, "unsupported medium type '" + type + "' (homogeneous, heterogeneous)");
    const bool heterogeneous = type == "heterogeneous";
    Props p(ctx_, node, "medium '" + type + "'");
    Medium m;
    m.where = ctx_.where(node);
    if (std::optional<glm::vec3> s = p.get_color("sigma_t")) {
      if (!non_negative(*s)) p.fail("sigma_t", "sigma_t must not be negative");
      m.sigma_t = *s;
    }
    if (std::optional<glm::vec3> a = p.get_color("albedo")) {
      if (!in_unit_range(*a)) p.fail("albedo", "albedo must be in [0, 1]");
      m.albedo = *a;
    }
    float scale = 1.0f;
    if (std::optional<float> s = p.get_float("scale")) {
      if (!(*s >= 0.0f)) p.fail("scale", "scale of a medium must not be negative");
      scale = *s;
    }
    p.finish();
    bool have_phase = false;
    std::set<std::string> volumes;  // the coefficients given as a <volume>
    for (const pugi::xml_node& child : p.objects()) {
      const std::string tag = child.name();
      if (heterogeneous && tag == "volume") {
        read_medium_volume(child, p, m, volumes);
        continue;
      }
      if (tag != "phase")
        ctx_.fail(child, "<" + tag + "> is not allowed in " + p.what() +
                             (heterogeneous ? " (only <phase> and <volume>)" : " (only <phase>)"));
      if (have_phase) ctx_.fail(child, "a second <phase> in the medium");
      have_phase = true;
      read_phase(child, m);
    }
    m.sigma_t *= scale;
    if (m.albedo_grid >= 0) {
      const float top = scene_.volumes[m.albedo_grid].grid.max_value() * std::max({m.albedo.x, m.albedo.y, m.albedo.z});
      if (top > 1.0f)
        ctx_.fail(node, "the albedo volume reaches " + std::to_string(top) + " (albedo must be in [0, 1])");
    }
    int index = static_cast<int>(scene_.media.size());
    scene_.media.push_back(m);
    register_id(node, index);
    return index;
  }

  // <volume name="sigma_t|albedo" type="gridvolume|constvolume"> of a
  // heterogeneous medium (SCENES.md), as Mitsuba 3 reads it: a constvolume
  // sets the coefficient, a gridvolume makes it the grid's value (times the
  // medium's scale for sigma_t).
  void read_medium_volume(const pugi::xml_node& node, const Props& medium, Medium& m, std::set<std::string>& given) {
    const std::string type = object_type(node);
    const std::string name = ctx_.attr(node, "name");
    if (name != "sigma_t" && name != "albedo")
      ctx_.fail(node, "<volume name=\"" + name + "\"> in " + medium.what() + " (sigma_t or albedo)");
    if (medium.has(name.c_str()) || !given.insert(name).second)
      ctx_.fail(node, name + " of " + medium.what() + " is given twice");
    Props p(ctx_, node, "volume '" + type + "'");
    if (type == "constvolume") {
      std::optional<glm::vec3> v = p.get_color("value");
      const glm::vec3 value = v.value_or(glm::vec3(1.0f));
      if (name == "sigma_t" && !non_negative(value)) p.fail("value", "sigma_t must not be negative");
      if (name == "albedo" && !in_unit_range(value)) p.fail("value", "albedo must be in [0, 1]");
      (name == "sigma_t" ? m.sigma_t : m.albedo) = value;
    } else if (type == "gridvolume") {
      (name == "sigma_t" ? m.sigma_t_grid : m.albedo_grid) = read_gridvolume(node, p);
      (name == "sigma_t" ? m.sigma_t : m.albedo) = glm::vec3(1.0f);
    } else {
      ctx_.fail(node, "unsupported volume type '" + type + "' (gridvolume, constvolume)");
    }
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  int read_gridvolume(const pugi::xml_node& node, Props& p) {
    GridVolume v;
    v.where = ctx_.where(node);
    std::optional<std::string> filename = p.get_string("filename");
    if (!filename) ctx_.fail(node, p.what() + " needs a 'filename' property");
    const std::string grid_name = p.get_string("grid").value_or("density");
    const std::string path = ctx_.resolve(*filename);
    const bool vdb = path.size() >= 4 && path.compare(path.size() - 4, 4, ".vdb") == 0;
    if (!vdb && p.has("grid")) p.fail("grid", "'grid' names a grid of an OpenVDB (.vdb) file, not of a .vol");
    try {
      v.grid = vdb ? read_vdb(path, grid_name) : read_vol(path);
    } catch (const InputError& e) {
      throw InputError(v.where, e.what());
    }
    const std::string filter = p.get_string("filter_type").value_or("trilinear");
    if (filter != "trilinear" && filter != "nearest")
      p.fail("filter_type", "filter_type must be trilinear or nearest, not '" + filter + "'");
    v.nearest = filter == "nearest";
    const std::string wrap = p.get_string("wrap_mode").value_or("clamp");
    if (wrap != "clamp") p.fail("wrap_mode", "wrap_mode '" + wrap + "' is not supported (clamp)");
    v.to_world = p.get_transform("to_world").value_or(glm::mat4(1.0f));
    if (p.get_bool("use_grid_bbox").value_or(false)) {
      const glm::vec3 extent = v.grid.bbox_max - v.grid.bbox_min;
      if (!(extent.x > 0.0f && extent.y > 0.0f && extent.z > 0.0f))
        ctx_.fail(node, "use_grid_bbox: the grid file's bounding box is empty");
      v.to_world = v.to_world * glm::translate(glm::mat4(1.0f), v.grid.bbox_min) * glm::scale(glm::mat4(1.0f), extent);
    }
    if (glm::determinant(glm::mat3(v.to_world)) == 0.0f) ctx_.fail(node, "to_world of the gridvolume is singular");
    scene_.volumes.push_back(std::move(v));
    return static_cast<int>(scene_.volumes.size()) - 1;
  }

  void read_phase(const pugi::xml_node& node, Medium& m) {
    std::string type = object_type(node);
    if (type != "isotropic" && type != "hg") ctx_.fail(node, "unsupported phase type '" + type + "' (isotropic, hg)");
    Props p(ctx_, node, "phase '" + type + "'");
    if (type == "isotropic") {
      m.hg = false;
    } else {
      m.hg = true;
      m.g = 0.8f;  // Mitsuba's default
      if (std::optional<float> g = p.get_float("g")) {
        if (!(*g > -1.0f && *g < 1.0f)) p.fail("g", "g of the hg phase function must be in (-1, 1)");
        m.g = *g;
      }
    }
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  // ---- integrator ---------------------------------------------------------

  // type="spm" holds every setting. Mitsuba's path tracers (volpath,
  // volpathmis, path) render with spm's method: their max_depth and
  // rr_depth mean what spm's do (METHOD.md 10) and every other setting is
  // derived. Any other integrator is left to the renderer it is written for.
  void parse_integrator(const pugi::xml_node& node) {
    std::string type = object_type(node);
    if (have_integrator_) ctx_.fail(node, "a second <integrator> (only one per scene)");
    have_integrator_ = true;
    if (type == "moment" || type == "aov") {
      parse_wrapper_integrator(node, type);
      return;
    }
    if (type == "volpath" || type == "volpathmis" || type == "path") {
      parse_path_integrator(node, type);
      return;
    }
    if (type != "spm") return;
    Props p(ctx_, node, "integrator 'spm'");
    IntegratorSettings& s = scene_.integrator;
    s.present = true;
    s.where = ctx_.where(node);
    read_settings(p, s);
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  // Mitsuba's moment and aov integrators only add outputs (the moments or
  // the AOVs of what they wrap): the image is that of the integrator nested
  // in them, the first when moment holds several. An aov without one renders
  // no radiance in Mitsuba; spm renders its own then.
  void parse_wrapper_integrator(const pugi::xml_node& node, const std::string& type) {
    Props p(ctx_, node, "integrator '" + type + "'");
    if (type == "aov") p.get_string("aovs");
    p.finish();
    for (const pugi::xml_node& child : p.objects())
      if (std::string(child.name()) != "integrator")
        ctx_.fail(child, "<" + std::string(child.name()) + "> is not allowed in " + p.what());
    register_id(node, -1);
    if (p.objects().empty()) return;
    const pugi::xml_node& inner = p.objects().front();
    if (p.objects().size() > 1)
      std::cerr << ctx_.where(node) << ": warning: " << p.what() << " wraps " << p.objects().size()
                << " integrators; spm renders the first (" << ctx_.where(inner) << ")\n";
    have_integrator_ = false;
    parse_integrator(inner);
  }

  void parse_path_integrator(const pugi::xml_node& node, const std::string& type) {
    Props p(ctx_, node, "integrator '" + type + "'");
    IntegratorSettings& s = scene_.integrator;
    s.integrator_type = type;
    s.where = ctx_.where(node);
    read_setting(p, setting("max_depth"), s);
    read_setting(p, setting("rr_depth"), s);
    if (p.get_bool("hide_emitters").value_or(false)) {
      p.fail("hide_emitters", "hide_emitters=true is not supported: spm draws the lights the camera sees");
    }
    p.finish();
    no_objects(p);
    register_id(node, -1);
  }

  xml::Context ctx_;
  Scene scene_;
  std::map<std::string, Named> ids_;
  bool have_sensor_ = false;
  bool have_integrator_ = false;
};

}  // namespace

Scene load_scene_string(const std::string& xml, const std::string& name,
                        const std::map<std::string, std::string>& overrides) {
  return Loader(overrides).load(xml, name);
}

Scene load_scene(const std::string& path, const std::map<std::string, std::string>& overrides) {
  return load_scene_string(xml::read_text_file(path, path, "scene file"), path, overrides);
}

}  // namespace spm
