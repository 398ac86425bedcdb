#include "scene/ply.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>
#include <unordered_set>
#include <vector>

#include "util/errors.h"

namespace spm {

namespace {

enum class Format { kAscii, kLittleEndian, kBigEndian };

// In the order of kTypes.
enum class Type : uint8_t { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

struct TypeInfo {
  const char* name;
  const char* alias;
  size_t size;
  int64_t min, max;  // of an integer type, for ascii values
};

constexpr TypeInfo kTypes[] = {
    {"char", "int8", 1, INT8_MIN, INT8_MAX},
    {"uchar", "uint8", 1, 0, UINT8_MAX},
    {"short", "int16", 2, INT16_MIN, INT16_MAX},
    {"ushort", "uint16", 2, 0, UINT16_MAX},
    {"int", "int32", 4, INT32_MIN, INT32_MAX},
    {"uint", "uint32", 4, 0, UINT32_MAX},
    {"float", "float32", 4, 0, 0},
    {"double", "float64", 8, 0, 0},
};

const TypeInfo& info(Type t) { return kTypes[static_cast<size_t>(t)]; }

bool is_integer(Type t) { return t != Type::kFloat32 && t != Type::kFloat64; }

bool parse_type(std::string_view word, Type* type) {
  for (size_t i = 0; i < std::size(kTypes); ++i) {
    if (word == kTypes[i].name || word == kTypes[i].alias) {
      *type = static_cast<Type>(i);
      return true;
    }
  }
  return false;
}

// Where a vertex property's value goes in the mesh.
enum Slot : int { kSkip = -1, kX, kY, kZ, kNX, kNY, kNZ, kU, kV, kSlots };

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // of the value, or of a list's items
  bool list = false;
  Type count_type = Type::kUInt8;  // of a list's length
  size_t line = 0;                 // in the header
  int slot = kSkip;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  size_t line = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  size_t data_offset = 0;  // of the first byte after the end_header line
  size_t lines = 0;        // header lines: ascii data lines are numbered on from here
};

// `s` fit for a one-line message: bytes other than printable ASCII escaped,
// a long word cut (header words and ascii values come from arbitrary bytes).
std::string shown(std::string_view s) {
  constexpr size_t kMax = 40;
  std::string out;
  for (size_t i = 0; i < s.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[5];
      std::snprintf(hex, sizeof(hex), "\\x%02x", c);
      out += hex;
    }
  }
  if (s.size() > kMax) out += "...";
  return out;
}

std::string quoted(std::string_view s) { return "'" + shown(s) + "'"; }

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// A value of an integer type (all fit in a long long) as it was written.
std::string integer_text(double v) { return std::to_string(static_cast<long long>(v)); }

struct Errors {
  const std::string& name;
  const std::string& where;

  [[noreturn]] void in_file(const std::string& problem) const {
    throw InputError(where, "PLY file " + name + ": " + problem);
  }
  [[noreturn]] void at_line(size_t line, const std::string& problem) const {
    throw InputError(where, "PLY file " + name + ":" + std::to_string(line) + ": " + problem);
  }
};

// '\r' counts as a blank so that header and ascii lines may end in "\r\n".
bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

void split(std::string_view line, std::vector<std::string_view>* words) {
  words->clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    const size_t begin = i;
    while (i < line.size() && !is_blank(line[i])) ++i;
    if (i > begin) words->push_back(line.substr(begin, i - begin));
  }
}

Header parse_header(const std::string& bytes, const Errors& err) {
  Header h;
  bool format_seen = false;
  std::vector<std::string_view> words;
  std::unordered_set<std::string> property_names;  // of the current element
  size_t pos = 0, line = 0;
  for (;;) {
    if (pos == bytes.size() && line > 0) err.at_line(line, "the header has no end_header line");
    const size_t newline = bytes.find('\n', pos);
    const size_t end = newline == std::string::npos ? bytes.size() : newline;
    split(std::string_view(bytes).substr(pos, end - pos), &words);
    pos = newline == std::string::npos ? bytes.size() : newline + 1;
    ++line;
    if (line == 1) {
      if (words.size() != 1 || words[0] != "ply") err.in_file("not a PLY file (the first line is not \"ply\")");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    const std::string_view key = words[0];
    if (key == "format") {
      if (format_seen) err.at_line(line, "a second format line");
      if (words.size() != 3) err.at_line(line, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      if (words[1] == "ascii") {
        h.format = Format::kAscii;
      } else if (words[1] == "binary_little_endian") {
        h.format = Format::kLittleEndian;
      } else if (words[1] == "binary_big_endian") {
        h.format = Format::kBigEndian;
      } else {
        err.at_line(line, "unknown format " + quoted(words[1]) + " (ascii, binary_little_endian or binary_big_endian)");
      }
      if (words[2] != "1.0") err.at_line(line, "unknown PLY version " + quoted(words[2]) + " (1.0 expected)");
      format_seen = true;
    } else if (key == "element") {
      if (!format_seen) err.at_line(line, "an element before the format line");
      if (words.size() != 3) err.at_line(line, "expected 'element NAME COUNT'");
      Element e;
      e.name = std::string(words[1]);
      e.line = line;
      const std::string_view count = words[2];
      const auto [end_of_count, ec] = std::from_chars(count.data(), count.data() + count.size(), e.count);
      if (ec == std::errc::result_out_of_range) err.at_line(line, "element count " + quoted(count) + " is too large");
      if (ec != std::errc() || end_of_count != count.data() + count.size())
        err.at_line(line, "element count " + quoted(count) + " is not a whole number");
      if ((e.name == "vertex" || e.name == "face") &&
          std::any_of(h.elements.begin(), h.elements.end(), [&](const Element& o) { return o.name == e.name; }))
        err.at_line(line, "a second " + e.name + " element");
      h.elements.push_back(std::move(e));
      property_names.clear();
    } else if (key == "property") {
      if (h.elements.empty()) err.at_line(line, "a property before any element");
      Property p;
      p.line = line;
      p.list = words.size() >= 2 && words[1] == "list";
      if (words.size() != (p.list ? 5u : 3u))
        err.at_line(line, "expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME'");
      const std::string_view type = words[p.list ? 3 : 1];
      if (p.list) {
        if (!parse_type(words[2], &p.count_type)) err.at_line(line, "unknown property type " + quoted(words[2]));
        if (!is_integer(p.count_type))
          err.at_line(line, "a list's length type must be an integer type, not " + std::string(words[2]));
      }
      if (!parse_type(type, &p.type)) err.at_line(line, "unknown property type " + quoted(type));
      p.name = std::string(words.back());
      if (!property_names.insert(p.name).second)
        err.at_line(line, "a second property " + quoted(p.name) + " in element " + quoted(h.elements.back().name));
      h.elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      if (words.size() != 1) err.at_line(line, "unexpected words after end_header");
      if (!format_seen) err.at_line(line, "the header has no format line");
      break;
    } else {
      err.at_line(line, "unknown header keyword " + quoted(key));
    }
  }
  h.data_offset = pos;
  h.lines = line;
  return h;
}

// The elements and properties the mesh comes from.
struct Layout {
  const Element* vertex = nullptr;
  const Element* face = nullptr;
  size_t index_property = 0;  // of the face element
  bool normals = false;
  bool uvs = false;
};

// Finds the vertex and face elements and gives the vertex properties their
// slots; refuses a file that lacks what a mesh needs.
Layout prepare(Header& h, bool vertex_normals, const Errors& err) {
  Layout layout;
  Element* vertex = nullptr;
  for (Element& e : h.elements) {
    if (e.name == "vertex") vertex = &e;
    if (e.name == "face") layout.face = &e;
  }
  if (!layout.face || layout.face->count == 0) err.in_file("the file has no faces");
  if (!vertex) err.in_file("the file has no vertex element");
  // Only a file of over 12 GiB gets here: check_counts allows at least 3 bytes a vertex.
  if (vertex->count > UINT32_MAX)
    err.at_line(vertex->line, std::to_string(vertex->count) + " vertices are too many (at most 4294967295)");
  layout.vertex = vertex;

  auto find = [&](const char* name) -> Property* {
    for (Property& p : vertex->properties)
      if (p.name == name) return &p;
    return nullptr;
  };
  static const char* const kPosition[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    Property* p = find(kPosition[i]);
    if (!p) err.at_line(vertex->line, "the vertex element has no '" + std::string(kPosition[i]) + "' property");
    p->slot = kX + i;
  }
  static const char* const kNormal[3] = {"nx", "ny", "nz"};
  Property* normal[3] = {find(kNormal[0]), find(kNormal[1]), find(kNormal[2])};
  const int normals = (normal[0] != nullptr) + (normal[1] != nullptr) + (normal[2] != nullptr);
  if (normals != 0 && normals != 3) {
    std::string missing;
    for (int i = 0; i < 3; ++i)
      if (!normal[i]) missing += (missing.empty() ? "" : " and ") + std::string(kNormal[i]);
    err.at_line(vertex->line, "vertex normals need nx, ny and nz; the vertex element lacks " + missing);
  }
  if (normals == 3 && vertex_normals) {
    for (int i = 0; i < 3; ++i) normal[i]->slot = kNX + i;
    layout.normals = true;
  }
  // Mitsuba's names for texture coordinates; the first pair present wins.
  static const char* const kUv[][2] = {{"u", "v"}, {"texture_u", "texture_v"}, {"s", "t"}, {"texture_s", "texture_t"}};
  for (const auto& names : kUv) {
    Property* u = find(names[0]);
    Property* v = find(names[1]);
    if (u && v) {
      u->slot = kU;
      v->slot = kV;
      layout.uvs = true;
      break;
    }
  }
  for (const Property& p : vertex->properties)
    if (p.slot != kSkip && p.list)
      err.at_line(p.line, "vertex property " + quoted(p.name) + " is a list, not a number");

  const Element& face = *layout.face;
  size_t index_property = face.properties.size();
  for (const char* name : {"vertex_indices", "vertex_index"}) {
    for (size_t i = 0; i < face.properties.size() && index_property == face.properties.size(); ++i)
      if (face.properties[i].name == name) index_property = i;
  }
  if (index_property == face.properties.size())
    err.at_line(face.line, "the face element has no vertex_indices (or vertex_index) list");
  const Property& indices = face.properties[index_property];
  if (!indices.list) err.at_line(indices.line, "face property " + indices.name + " is not a list");
  if (!is_integer(indices.type))
    err.at_line(indices.line, "face property " + indices.name + " has " + info(indices.type).name +
                                  " items (vertex indices must be integers)");
  layout.index_property = index_property;
  return layout;
}

// The fewest bytes a record of `e` takes: in binary its scalars and list
// lengths, in ascii a digit and a blank or line end per value.
uint64_t min_record_bytes(const Element& e, bool ascii) {
  uint64_t bytes = 0;
  for (const Property& p : e.properties) bytes += ascii ? 2 : info(p.list ? p.count_type : p.type).size;
  return bytes;
}

// Refuses, before anything is allocated for them, element counts that the
// bytes after the header cannot hold (a truncated file, or a corrupt count
// such as 2^40 vertices).
void check_counts(const Header& h, size_t data_bytes, const Errors& err) {
  const bool ascii = h.format == Format::kAscii;
  uint64_t left = data_bytes + (ascii ? 1 : 0);  // the last ascii value needs no line end
  for (const Element& e : h.elements) {
    const uint64_t record = min_record_bytes(e, ascii);
    if (record == 0) continue;
    if (e.count > left / record)
      err.at_line(e.line, "the file is too short for " + std::to_string(e.count) + " " + shown(e.name) +
                              " records (at least " + std::to_string(record) + " bytes each, " + std::to_string(left) +
                              " bytes left): truncated, or a wrong count");
    left -= e.count * record;
  }
}

// Binary records, read in place. Every read checks the bytes left, since
// list lengths come from the data.
class BinaryReader {
 public:
  BinaryReader(const char* begin, const char* end, bool swap, const Errors& err)
      : p_(begin), end_(end), swap_(swap), err_(err) {}

  void start(const Element& e, uint64_t index) {
    element_ = &e;
    index_ = index;
  }
  void finish() {}

  double value(const Property&, Type t) {
    switch (t) {
      case Type::kInt8:
        return take<int8_t>();
      case Type::kUInt8:
        return take<uint8_t>();
      case Type::kInt16:
        return take<int16_t>();
      case Type::kUInt16:
        return take<uint16_t>();
      case Type::kInt32:
        return take<int32_t>();
      case Type::kUInt32:
        return take<uint32_t>();
      case Type::kFloat32:
        return take<float>();
      case Type::kFloat64:
        return take<double>();
    }
    return 0.0;
  }
  void skip(const Property&, Type t) { advance(1, info(t).size); }

  uint64_t list_length(const Property& p) {
    const double n = value(p, p.count_type);
    if (n < 0) fail("negative length " + integer_text(n) + " of list " + quoted(p.name));
    const uint64_t length = static_cast<uint64_t>(n);
    if (length > static_cast<size_t>(end_ - p_) / info(p.type).size) truncated();
    return length;
  }
  void skip_items(const Property& p, uint64_t n) { advance(n, info(p.type).size); }

  void check_end() const {
    const size_t left = static_cast<size_t>(end_ - p_);
    if (left != 0)
      err_.in_file(std::to_string(left) + (left == 1 ? " byte" : " bytes") +
                   " of data after the last element (trailing content)");
  }

  [[noreturn]] void fail(const std::string& problem) const {
    err_.in_file(shown(element_->name) + " " + std::to_string(index_) + ": " + problem);
  }

 private:
  [[noreturn]] void truncated() const {
    err_.in_file("the data ends inside " + shown(element_->name) + " " + std::to_string(index_) + " (truncated file)");
  }

  void advance(uint64_t n, size_t size) {
    if (n > static_cast<size_t>(end_ - p_) / size) truncated();
    p_ += n * size;
  }

  template <typename T>
  T take() {
    if (static_cast<size_t>(end_ - p_) < sizeof(T)) truncated();
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, p_, sizeof(T));
    if (swap_) std::reverse(raw, raw + sizeof(T));
    p_ += sizeof(T);
    T v;
    std::memcpy(&v, raw, sizeof(T));
    return v;
  }

  const char* p_;
  const char* end_;
  bool swap_;
  const Errors& err_;
  const Element* element_ = nullptr;
  uint64_t index_ = 0;
};

// Ascii records, one per line, values separated by blanks; blank lines are
// skipped.
class AsciiReader {
 public:
  AsciiReader(const std::string& bytes, size_t offset, size_t header_lines, const Errors& err)
      : next_(bytes.data() + offset), end_(bytes.data() + bytes.size()), line_(header_lines), err_(err) {}

  void start(const Element& e, uint64_t index) {
    element_ = &e;
    index_ = index;
    if (!next_line()) err_.at_line(line_, "the data ends before " + record() + " (truncated file)");
  }
  void finish() {
    skip_blanks();
    if (cur_ != line_end_) fail("more values on the line than the " + shown(element_->name) + " element has");
  }

  double value(const Property& p, Type t) {
    skip_blanks();
    const char* begin = cur_;
    while (cur_ != line_end_ && !is_blank(*cur_)) ++cur_;
    const std::string_view word(begin, static_cast<size_t>(cur_ - begin));
    if (word.empty()) fail("too few values on the line (none for " + quoted(p.name) + ")");
    if (is_integer(t)) {
      int64_t v = 0;
      const auto [end, ec] = std::from_chars(begin, cur_, v);
      if (ec != std::errc() || end != cur_ || v < info(t).min || v > info(t).max)
        fail(quoted(word) + " is not of type " + info(t).name + " (" + quoted(p.name) + ")");
      return static_cast<double>(v);
    }
    double v = 0.0;
    const auto [end, ec] = std::from_chars(begin, cur_, v);
    if (ec == std::errc::result_out_of_range) fail(quoted(word) + " is out of range (" + quoted(p.name) + ")");
    if (ec != std::errc() || end != cur_) fail(quoted(word) + " is not a number (" + quoted(p.name) + ")");
    return v;
  }
  void skip(const Property& p, Type t) { value(p, t); }

  uint64_t list_length(const Property& p) {
    const double n = value(p, p.count_type);
    if (n < 0) fail("negative length " + integer_text(n) + " of list " + quoted(p.name));
    return static_cast<uint64_t>(n);
  }
  void skip_items(const Property& p, uint64_t n) {
    for (uint64_t i = 0; i < n; ++i) value(p, p.type);
  }

  void check_end() {
    if (next_line()) err_.at_line(line_, "data after the last element (trailing content)");
  }

  [[noreturn]] void fail(const std::string& problem) const { err_.at_line(line_, record() + ": " + problem); }

 private:
  std::string record() const { return shown(element_->name) + " " + std::to_string(index_); }

  void skip_blanks() {
    while (cur_ != line_end_ && is_blank(*cur_)) ++cur_;
  }

  // Moves to the next line with a value on it; false at the end of the data.
  bool next_line() {
    while (next_ != end_) {
      const void* newline = std::memchr(next_, '\n', static_cast<size_t>(end_ - next_));
      cur_ = next_;
      line_end_ = newline ? static_cast<const char*>(newline) : end_;
      next_ = newline ? line_end_ + 1 : end_;
      ++line_;
      skip_blanks();
      if (cur_ != line_end_) return true;
    }
    return false;
  }

  const char* next_;
  const char* end_;
  const char* cur_ = nullptr;
  const char* line_end_ = nullptr;
  size_t line_;
  const Errors& err_;
  const Element* element_ = nullptr;
  uint64_t index_ = 0;
};

template <typename Reader>
void skip_property(Reader& in, const Property& p) {
  if (p.list)
    in.skip_items(p, in.list_length(p));
  else
    in.skip(p, p.type);
}

template <typename Reader>
float finite_float(Reader& in, const Property& p, double v) {
  if (std::isnan(v) || std::isinf(v)) in.fail("non-finite " + p.name + " (" + number_text(v) + ")");
  if (std::abs(v) > std::numeric_limits<float>::max())
    in.fail("non-finite " + p.name + " as a float (" + number_text(v) + " is beyond its range)");
  return static_cast<float>(v);
}

template <typename Reader>
void read_vertices(Reader& in, const Layout& layout, Mesh& mesh) {
  const Element& e = *layout.vertex;
  const size_t count = static_cast<size_t>(e.count);
  mesh.positions.resize(count);
  if (layout.normals) mesh.normals.resize(count);
  if (layout.uvs) mesh.uvs.resize(count);
  float v[kSlots] = {};
  for (size_t i = 0; i < count; ++i) {
    in.start(e, i);
    for (const Property& p : e.properties) {
      if (p.list)
        in.skip_items(p, in.list_length(p));
      else if (p.slot == kSkip)
        in.skip(p, p.type);
      else
        v[p.slot] = finite_float(in, p, in.value(p, p.type));
    }
    in.finish();
    mesh.positions[i] = glm::vec3(v[kX], v[kY], v[kZ]);
    if (layout.normals) mesh.normals[i] = glm::vec3(v[kNX], v[kNY], v[kNZ]);
    if (layout.uvs) mesh.uvs[i] = glm::vec2(v[kU], v[kV]);
  }
}

template <typename Reader>
void read_faces(Reader& in, const Layout& layout, Mesh& mesh) {
  const Element& e = *layout.face;
  const Property& indices = e.properties[layout.index_property];
  // Indices are integers (prepare() refuses float items), so doubles hold them exactly.
  const double vertices = static_cast<double>(layout.vertex->count);
  auto index = [&]() -> uint32_t {
    const double v = in.value(indices, indices.type);
    if (v < 0) in.fail("negative vertex index " + integer_text(v));
    if (v >= vertices)
      in.fail("vertex index " + integer_text(v) + " out of range (" + std::to_string(layout.vertex->count) +
              " vertices)");
    return static_cast<uint32_t>(v);
  };
  for (uint64_t i = 0; i < e.count; ++i) {
    in.start(e, i);
    for (size_t k = 0; k < e.properties.size(); ++k) {
      if (k != layout.index_property) {
        skip_property(in, e.properties[k]);
        continue;
      }
      const uint64_t n = in.list_length(indices);
      if (n < 3) in.fail(std::to_string(n) + " vertex indices (a face needs at least 3)");
      const uint32_t first = index();
      uint32_t previous = index();
      for (uint64_t j = 2; j < n; ++j) {
        const uint32_t next = index();
        mesh.triangles.emplace_back(first, previous, next);
        previous = next;
      }
    }
    in.finish();
  }
}

template <typename Reader>
void read_data(Reader& in, const Header& header, const Layout& layout, Mesh& mesh) {
  for (const Element& e : header.elements) {
    if (&e == layout.vertex) {
      read_vertices(in, layout, mesh);
    } else if (&e == layout.face) {
      read_faces(in, layout, mesh);
    } else if (!e.properties.empty()) {
      for (uint64_t i = 0; i < e.count; ++i) {
        in.start(e, i);
        for (const Property& p : e.properties) skip_property(in, p);
        in.finish();
      }
    }
  }
  in.check_end();
}

bool host_is_little_endian() {
  const uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

}  // namespace

Mesh parse_ply(const std::string& bytes, const std::string& name, bool vertex_normals, const std::string& where) {
  const Errors err{name, where};
  Header header = parse_header(bytes, err);
  const size_t data_bytes = bytes.size() - header.data_offset;
  check_counts(header, data_bytes, err);
  const Layout layout = prepare(header, vertex_normals, err);

  const bool ascii = header.format == Format::kAscii;
  Mesh mesh;
  // Every face gives at least one triangle and takes at least the bytes of a
  // record with 3 indices: reserving for that many is bounded by the file size.
  const Property& indices = layout.face->properties[layout.index_property];
  const uint64_t face_bytes = min_record_bytes(*layout.face, ascii) + 3 * (ascii ? 2 : info(indices.type).size);
  mesh.triangles.reserve(static_cast<size_t>(std::min<uint64_t>(layout.face->count, data_bytes / face_bytes)));
  if (ascii) {
    AsciiReader in(bytes, header.data_offset, header.lines, err);
    read_data(in, header, layout, mesh);
  } else {
    const bool swap = (header.format == Format::kLittleEndian) != host_is_little_endian();
    BinaryReader in(bytes.data() + header.data_offset, bytes.data() + bytes.size(), swap, err);
    read_data(in, header, layout, mesh);
  }
  return mesh;
}

}  // namespace spm
