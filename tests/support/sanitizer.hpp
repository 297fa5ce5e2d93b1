// Whether this test program is built with AddressSanitizer (make test-sanitize), where
// everything runs several times slower: tests with a timing window widen it there.
#pragma once

namespace arlight::test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace arlight::test
