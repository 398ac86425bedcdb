// tinyobjloader's implementation, compiled into the fuzz targets so that the
// sanitizers and libFuzzer's coverage see inside it (the build otherwise
// links Debian's libtinyobjloader.so, built from the same header).
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
