#include "scene/obj.h"

#include <tiny_obj_loader.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "util/errors.h"

namespace spm {

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string first_line(const std::string& s) {
  std::string line = s.substr(0, s.find('\n'));
  return line.empty() ? "unknown error" : line;
}

bool is_space(char c) { return c == ' ' || c == '\t'; }

// The whitespace-separated words of `s`.
std::vector<std::string> words(const std::string& s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_space(s[i])) ++i;
    size_t b = i;
    while (i < s.size() && !is_space(s[i])) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
  return out;
}

// A whole word as a decimal number that a float holds (tinyobjloader reads
// no other form, into floats).
bool parse_number(const std::string& word) {
  for (char c : word)
    if (!std::isdigit(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.' && c != 'e' && c != 'E')
      return false;
  const char* begin = word.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  return !word.empty() && end == begin + word.size() && std::abs(v) <= std::numeric_limits<float>::max();
}

// Checks every vertex and face line before tinyobjloader reads the text, so
// that a corrupt file is refused at its line: tinyobjloader names the line of
// some errors only, skips some bad faces with a warning or none (an index out
// of range in a polygon), reads a malformed number as 0, and an index beyond
// int's range is undefined behaviour in its atoi. tinyobjloader then gets
// only the lines the renderer uses (v, vn, vt, f): its readers of the others
// (its vw skin weights, t tags, l and p elements, materials) are undefined
// behaviour on some bad input (fuzz_obj found one), and their content is
// dropped anyway. Lines are split as
// tinyobjloader splits them ("\n", "\r\n" or "\r"; the text of a line ends at
// a NUL byte; trailing blanks dropped), and a directive is its first word,
// after leading blanks, when more follows.
class ObjChecker {
 public:
  ObjChecker(const std::string& text, std::function<void(size_t, const std::string&)> fail)
      : text_(text), fail_(std::move(fail)) {}

  void run() {
    // First pass: the number of positions, normals and texture coordinates,
    // since positive indices may refer to vertices defined later.
    scan([&](size_t, const std::string& directive, const std::string&) {
      if (directive == "v") ++total_[0];
      if (directive == "vn") ++total_[2];
      if (directive == "vt") ++total_[1];
    });
    size_t seen[3] = {0, 0, 0};  // defined so far, for relative (negative) indices
    scan([&](size_t line, const std::string& directive, const std::string& rest) {
      if (directive == "v" || directive == "vn" || directive == "vt") {
        // v: x y z, then w or r g b; vn: x y z; vt: u, v, w.
        std::vector<std::string> w = words(rest);
        const char* what = directive == "v" ? "vertex position" : directive == "vn" ? "vertex normal" : "texture coordinate";
        const size_t least = directive == "vt" ? 1 : 3;
        if (w.size() < least)
          fail_(line, std::string("a ") + what + " needs " + std::to_string(least) + " numbers, got " +
                          std::to_string(w.size()));
        for (const std::string& word : w)
          if (!parse_number(word)) fail_(line, std::string("malformed or non-finite ") + what + " '" + word + "'");
        ++seen[directive == "v" ? 0 : directive == "vt" ? 1 : 2];
      } else if (directive == "f") {
        check_face(line, rest, seen);
      }
    });
  }

  // The text with only the v, vn, vt and f lines, the others emptied (so that
  // line numbers stay), for tinyobjloader.
  std::string used_lines() const {
    std::string out;
    size_t last = 0;
    scan([&](size_t line, const std::string& directive, const std::string& rest) {
      if (directive != "v" && directive != "vn" && directive != "vt" && directive != "f") return;
      out.append(line - 1 - last, '\n');
      out += directive + rest + "\n";
      last = line;
    });
    return out;
  }

 private:
  template <typename F>
  void scan(F&& on_line) const {
    size_t line = 0, i = 0;
    while (i < text_.size()) {
      size_t end = i;
      while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
      ++line;
      std::string content = text_.substr(i, end - i);
      content = content.substr(0, content.find('\0'));
      content = content.substr(0, content.find_last_not_of(" \t") + 1);  // trailing blanks, as tinyobjloader
      i = end;
      if (i < text_.size()) i += (text_[i] == '\r' && i + 1 < text_.size() && text_[i + 1] == '\n') ? 2 : 1;
      size_t b = 0;
      while (b < content.size() && is_space(content[b])) ++b;
      size_t e = b;
      while (e < content.size() && !is_space(content[e])) ++e;
      // tinyobjloader only takes a directive followed by a blank ("f 1 2 3").
      if (e == content.size()) continue;
      on_line(line, content.substr(b, e - b), content.substr(e));
    }
  }

  // One index of a face corner: 1-based, or negative (relative to the
  // elements defined so far); `kind` 0 position, 1 texture coordinate, 2 normal.
  void check_index(size_t line, const std::string& word, const std::string& index, int kind, const size_t* seen) {
    static const char* const kNames[3] = {"vertex", "texture coordinate", "normal"};
    const char* begin = index.c_str();
    char* end = nullptr;
    errno = 0;
    long long v = std::strtoll(begin, &end, 10);
    if (index.empty() || end != begin + index.size() || !(std::isdigit(static_cast<unsigned char>(index.back()))))
      fail_(line, "malformed face corner '" + word + "'");
    if (v == 0) fail_(line, "a face refers to " + std::string(kNames[kind]) + " 0 (OBJ indices start at 1)");
    const long long total = static_cast<long long>(total_[kind]);
    if (v > 0 && (errno == ERANGE || v > total))
      fail_(line, "a face refers to " + std::string(kNames[kind]) + " " + index + " but the file has " +
                      std::to_string(total));
    if (v < 0 && (errno == ERANGE || -v > static_cast<long long>(seen[kind])))
      fail_(line, "a face refers to " + std::string(kNames[kind]) + " " + index + " (relative) but only " +
                      std::to_string(seen[kind]) + " precede it");
  }

  void check_face(size_t line, const std::string& rest, const size_t* seen) {
    std::vector<std::string> corners = words(rest);
    if (corners.size() < 3)
      fail_(line, "a face has " + std::to_string(corners.size()) + " vertices (at least 3 needed)");
    for (const std::string& word : corners) {
      // v, v/vt, v//vn or v/vt/vn
      std::string parts[3];
      size_t count = 0, b = 0;
      for (;;) {
        size_t slash = word.find('/', b);
        if (count == 3) fail_(line, "malformed face corner '" + word + "'");
        parts[count++] = word.substr(b, slash == std::string::npos ? std::string::npos : slash - b);
        if (slash == std::string::npos) break;
        b = slash + 1;
      }
      check_index(line, word, parts[0], 0, seen);
      if (count >= 2 && !(count == 3 && parts[1].empty())) check_index(line, word, parts[1], 1, seen);
      const bool normal = count == 3;
      if (normal) check_index(line, word, parts[2], 2, seen);
      if (normals_line_ == 0) {
        normals_line_ = line;
        with_normals_ = normal;
      } else if (normal != with_normals_) {
        fail_(line, "vertex normals on some faces only (this face " + std::string(normal ? "has" : "lacks") +
                        " them, the first face, line " + std::to_string(normals_line_) + ", " +
                        (with_normals_ ? "has" : "lacks") + " them)");
      }
    }
  }

  const std::string& text_;
  std::function<void(size_t, const std::string&)> fail_;
  size_t total_[3] = {0, 0, 0};
  size_t normals_line_ = 0;
  bool with_normals_ = false;
};

}  // namespace

Mesh parse_obj(const std::string& text, const std::string& name, bool vertex_normals, const std::string& where) {
  auto fail = [&](const std::string& problem) -> void { throw InputError(where, "OBJ file " + name + ": " + problem); };
  ObjChecker checker(text, [&](size_t line, const std::string& problem) {
    throw InputError(where, "OBJ file " + name + ":" + std::to_string(line) + ": " + problem);
  });
  checker.run();
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  std::istringstream in(checker.used_lines());
  // No material reader: the renderer takes materials from the scene file, so
  // mtllib lines are not followed.
  if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, nullptr, true, false)) fail(first_line(err));
  // tinyobjloader skips, with only a warning, polygons it cannot triangulate
  // and faces with fewer than 3 vertices: a corrupt file here.
  if (warn.find("invalid vertex index") != std::string::npos || warn.find("Degenerated face") != std::string::npos)
    fail(first_line(warn));

  const size_t num_positions = attrib.vertices.size() / 3;
  const size_t num_normals = attrib.normals.size() / 3;
  size_t corners = 0, corners_with_normal = 0;
  for (const tinyobj::shape_t& shape : shapes) {
    for (const tinyobj::index_t& idx : shape.mesh.indices) {
      ++corners;
      if (idx.normal_index >= 0) ++corners_with_normal;
    }
  }
  if (corners == 0) fail("no triangles");
  if (corners_with_normal != 0 && corners_with_normal != corners) fail("vertex normals on some faces only");
  const bool use_normals = vertex_normals && corners_with_normal == corners;

  Mesh mesh;
  std::unordered_map<uint64_t, uint32_t> vertex_of;  // (position, normal) index pair -> mesh vertex
  auto vertex = [&](const tinyobj::index_t& idx) -> uint32_t {
    if (idx.vertex_index < 0 || static_cast<size_t>(idx.vertex_index) >= num_positions)
      fail("a face refers to vertex " + std::to_string(idx.vertex_index + 1) + " but the file has " +
           std::to_string(num_positions));
    int n = use_normals ? idx.normal_index : -1;
    if (use_normals && static_cast<size_t>(n) >= num_normals)
      fail("a face refers to normal " + std::to_string(n + 1) + " but the file has " + std::to_string(num_normals));
    uint64_t key = (static_cast<uint64_t>(idx.vertex_index) << 32) | static_cast<uint32_t>(n);
    auto [it, inserted] = vertex_of.emplace(key, static_cast<uint32_t>(mesh.positions.size()));
    if (inserted) {
      const float* p = &attrib.vertices[3 * static_cast<size_t>(idx.vertex_index)];
      mesh.positions.emplace_back(p[0], p[1], p[2]);
      if (!finite(mesh.positions.back())) fail("non-finite vertex position");
      if (use_normals) {
        const float* q = &attrib.normals[3 * static_cast<size_t>(n)];
        mesh.normals.emplace_back(q[0], q[1], q[2]);
        if (!finite(mesh.normals.back())) fail("non-finite vertex normal");
      }
    }
    return it->second;
  };

  for (const tinyobj::shape_t& shape : shapes) {
    size_t offset = 0;
    for (unsigned char count : shape.mesh.num_face_vertices) {
      if (count != 3) fail("a face could not be triangulated");
      const tinyobj::index_t* f = &shape.mesh.indices[offset];
      mesh.triangles.emplace_back(vertex(f[0]), vertex(f[1]), vertex(f[2]));
      offset += count;
    }
  }
  return mesh;
}

}  // namespace spm
