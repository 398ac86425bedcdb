// Compile-time check that the host sees the shared structs at the sizes the
// kernels were written for (kernels/spm_layout.h); the layout test checks the
// device's view at run time.
#include <cstddef>
#include <type_traits>

#include "spm_layout.h"

#define SPM_ASSERT_SIZE(T, expected) \
  static_assert(sizeof(T) == (expected), #T " changed size: update spm_layout.h and the kernels");
#define SPM_ASSERT_STANDARD(T, expected) static_assert(std::is_standard_layout_v<T>, #T " must be plain C");

SPM_LAYOUT_STRUCTS(SPM_ASSERT_SIZE)
SPM_LAYOUT_STRUCTS(SPM_ASSERT_STANDARD)
