// Mitsuba's serialized meshes (shape type="serialized"): a binary container of
// zlib-compressed indexed triangle meshes, read by hand with zlib's inflate.
#pragma once

#include <string>

#include "scene/mesh.h"

namespace spm {

// Parses shape `shape_index` of the serialized file `name` whose content is
// `bytes` (format versions 3 and 4, little endian, as Mitsuba 3 reads them).
// Shape 0 starts at the beginning of the file, as in Mitsuba, so a file
// without the end-of-file offset table still gives its first shape; any other
// shape is found through that table. Returns positions, the file's normals
// unless `vertex_normals` is false (face_normals="true") and empty normals when
// the file has none (the caller computes smooth ones), uvs when the file has
// them, and the triangles; vertex colors are read and dropped. Throws
// InputError(where, ...) naming `name` and the shape for a corrupt file: bad
// header or version, shape index or offset out of range, a corrupt, truncated
// or over-long zlib stream, counts the data cannot hold, non-finite numbers,
// an index out of range, or no triangles. Memory stays bounded by what the
// compressed data can actually decompress to, whatever the counts claim.
Mesh parse_serialized(const std::string& bytes, const std::string& name, int shape_index, bool vertex_normals,
                      const std::string& where);

}  // namespace spm
