// What kind of build this is, for the few timings that must widen under it.
#pragma once

namespace arlight {

// Built with AddressSanitizer (make test-sanitize): everything runs several times slower.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitizedBuild = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitizedBuild = true;
#else
inline constexpr bool kSanitizedBuild = false;
#endif
#else
inline constexpr bool kSanitizedBuild = false;
#endif

}  // namespace arlight
