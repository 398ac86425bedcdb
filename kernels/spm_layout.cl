/* spm_layout: reports the device's sizeof of every shared struct, then the
 * offset of every field, in the order of spm_layout.h. One work-item. */
#include "spm_layout.h"

#define SPM_REPORT_SIZE(T, expected) out[n++] = (uint)sizeof(T);
#define SPM_REPORT_OFFSET(T, f) \
  out[n++] = (uint)((__global char*)&((__global T*)probe)->f - (__global char*)probe);

__kernel void spm_layout(__global uint* out, __global const char* probe) {
  if (get_global_id(0) != 0) return;
  uint n = 0;
  SPM_LAYOUT_STRUCTS(SPM_REPORT_SIZE)
  SPM_LAYOUT_FIELDS(SPM_REPORT_OFFSET)
}
