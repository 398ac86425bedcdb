// The plain scene the loader produces: what a Mitsuba 3 file (SCENES.md subset)
// describes, resolved into world space. Nothing here knows about OpenCL.
#pragma once

#include <cmath>

#include <glm/glm.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "scene/volume_grid.h"

namespace spm {

// A unit vector perpendicular to the unit vector w (for the frames of
// cylinders and of the disks lights at infinity start from).
inline glm::vec3 unit_perpendicular(const glm::vec3& w) {
  return glm::normalize(glm::cross(std::abs(w.x) > 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0), w));
}

struct Material {
  // Mitsuba's bsdf types; their lobes are in docs/METHOD.md 13.
  enum class Type { Diffuse, Conductor, Dielectric, ThinDielectric, Null, RoughConductor, RoughDielectric, Plastic };
  enum class Distribution { Beckmann, GGX };
  Type type = Type::Diffuse;
  glm::vec3 reflectance{0.5f};  // diffuse reflectance (diffuse: Mitsuba's default 0.5; plastic's too)
  glm::vec3 specular{1.0f};     // specular_reflectance of conductors and the plastic's coat
  glm::vec3 eta{0.0f};          // conductors' complex index eta + i k; material "none" (a perfect
  glm::vec3 k{1.0f};            // mirror) by default
  float int_ior = 1.5046f;      // Mitsuba's (thin, rough)dielectric defaults: bk7 inside,
  float ext_ior = 1.000277f;    // air outside (plastic: polypropylene inside)
  float alpha = 0.1f;           // microfacet roughness (Mitsuba's default)
  Distribution distribution = Distribution::Beckmann;
  bool nonlinear = false;       // plastic
  bool twosided = false;
  std::string where;  // "file:line" of the element, for messages
  // Opaque: light only reflects (no medium changes across it).
  bool opaque() const {
    return type == Type::Diffuse || type == Type::Conductor || type == Type::RoughConductor || type == Type::Plastic;
  }
  // Only a delta lobe: where a pixel's emission chains start (kernels'
  // is_specular).
  bool delta_only() const {
    return type == Type::Conductor || type == Type::Dielectric || type == Type::ThinDielectric;
  }
};

struct Medium {
  // Homogeneous: the coefficients. Heterogeneous (METHOD.md 12): factors on
  // the values of the grids sigma_t_grid and albedo_grid at a point, where
  // the medium names one (-1: the factor alone).
  glm::vec3 sigma_t{1.0f};  // already multiplied by `scale`
  glm::vec3 albedo{0.75f};  // Mitsuba 3's defaults
  int sigma_t_grid = -1;    // index into Scene::volumes
  int albedo_grid = -1;
  bool hg = false;          // phase: isotropic, or Henyey-Greenstein with g
  float g = 0.0f;
  std::string where;
  bool heterogeneous() const { return sigma_t_grid >= 0 || albedo_grid >= 0; }
};

// A gridvolume: the grid over the unit cube of to_world.
struct GridVolume {
  VolumeGrid grid;
  glm::mat4 to_world{1.0f};
  bool nearest = false;  // filter_type nearest, else trilinear
  std::string where;
};

struct Light {
  enum class Type { Area, Point, Spot, Directional, Envmap };
  Type type = Type::Area;
  glm::vec3 radiance{1.0f};    // area
  glm::vec3 intensity{1.0f};   // point, spot
  glm::vec3 irradiance{1.0f};  // directional
  glm::vec3 direction{0.0f, 0.0f, 1.0f};  // directional: where its light travels (world, unit)
  // envmap (and constant, a map of one texel): the lat-long map's linear RGB,
  // row by row from its top (theta 0), its scale and the rotation of its
  // to_world (columns: the map's x, y and z axes in the world).
  std::vector<glm::vec3> map;
  int map_width = 0, map_height = 0;
  float scale = 1.0f;
  glm::mat3 frame{1.0f};
  glm::vec3 position{0.0f};   // point, spot (world)
  glm::mat4 to_world{1.0f};   // spot: shines along its local +z
  float cutoff_angle = 20.0f;  // spot, degrees
  float beam_width = 15.0f;    // spot, degrees (Mitsuba: 3/4 of cutoff)
  int shape = -1;              // area: index of the shape it is attached to
  int medium = -1;             // medium the emitter sits in, -1: none
  // Whether the file says which medium (a point or spot light's nested
  // medium; an area light's shape naming an interior or exterior); if not,
  // the loader gives it the medium of its region (METHOD.md 9).
  bool medium_given = false;
  std::string where;
};

// A shape resolved to world space: a triangle mesh or an analytic sphere.
struct Shape {
  enum class Kind { Mesh, Sphere };
  Kind kind = Kind::Mesh;
  std::vector<glm::vec3> positions;  // mesh, world space
  std::vector<glm::vec3> normals;    // mesh, world space, per vertex; empty = flat
  std::vector<glm::uvec3> triangles;
  glm::vec3 center{0.0f};  // sphere, world space
  float radius = 1.0f;
  bool flip_normals = false;
  int material = -1;  // index into Scene::materials (always set after loading)
  int interior = -1;  // index into Scene::media, -1: none
  int exterior = -1;
  int light = -1;     // index into Scene::lights when the shape is an area emitter
  std::string where;
};

struct Camera {
  enum class FovAxis { X, Y, Smaller, Larger, Diagonal };
  enum class Filter { Box, Gaussian };
  glm::mat4 to_world{1.0f};  // camera looks along local +z, local +x is left
  float fov = 39.597755f;    // degrees; Mitsuba's default 50 mm focal length
  FovAxis fov_axis = FovAxis::X;
  float near_clip = 0.01f;
  float far_clip = 10000.0f;
  int width = 768;  // Mitsuba's hdrfilm defaults
  int height = 576;
  Filter filter = Filter::Gaussian;
  float filter_stddev = 0.5f;
  int spp = 4;  // sampler sample_count: the render's samples per pixel (Mitsuba's default 4)
  int medium = -1;
  std::string where;
};

// Where a setting's value came from (the settings line says).
enum class SettingSource { Default, Scene, CommandLine, Derived };

// The render's settings: the <integrator type="spm"> properties and the
// command line's flags. What each means, its range and its derivation are
// the table of scene/settings.h; the values here are the defaults, where 0
// (or -1) may stand for "derived" or "unlimited" as the table says.
struct IntegratorSettings {
  bool present = false;  // false when the file has no spm integrator
  // The integrator element the settings were read from: spm, or one of
  // Mitsuba's path tracers whose depths spm reads (the settings line says).
  std::string integrator_type = "spm";
  int streams = 0;
  int associated = 0;
  int beam_streams = 0;
  float radius = 0.0f;
  float stream_width = 0.0f;
  int max_bounces = -1;
  float march_step = 0.0f;
  int spp = 0;  // per pass
  int passes = 0;
  float time = 0.0f;
  float target_error = 0.0f;
  int seed = 0;
  int max_depth = -1;
  int rr_depth = 5;
  std::string estimator = "bre";
  std::string density_kernel = "uniform";
  std::string direct = "nee";
  bool final_gather = true;
  bool wall_images = true;
  float alpha = 0.9f;
  int emission_chains = 64;
  int volume_every = 4;
  float volume_radius = 0.0f;
  // By setting name; Default where absent.
  std::map<std::string, SettingSource> sources;
  SettingSource source(const std::string& name) const {
    const auto it = sources.find(name);
    return it == sources.end() ? SettingSource::Default : it->second;
  }
  std::string where;
};

struct Scene {
  std::string path;  // the file it was loaded from
  Camera camera;
  IntegratorSettings integrator;
  std::vector<Material> materials;
  std::vector<Medium> media;
  std::vector<GridVolume> volumes;
  std::vector<Light> lights;
  std::vector<Shape> shapes;
};

}  // namespace spm
