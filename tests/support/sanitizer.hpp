// Whether this test program is built with AddressSanitizer (make test-sanitize), where
// everything runs several times slower: tests with a timing window widen it there.
#pragma once

#include "arlight/common/build.hpp"

namespace arlight::test {

inline constexpr bool kSanitized = kSanitizedBuild;

}  // namespace arlight::test
