// Base64 (RFC 4648, '=' padding) for the "binary" encodings of VTK XML files. Private to the
// output library: VTK inline binary data is base64 text, so only an encoder is needed here.
#pragma once
#include <cstddef>
#include <string>

namespace pliant::detail {

// Appends the base64 encoding of the `size` bytes at `data` to `out` (padded to 4 characters).
void base64_append(const void* data, std::size_t size, std::string& out);

// Number of characters base64_append produces for `size` bytes.
constexpr std::size_t base64_length(std::size_t size) { return 4 * ((size + 2) / 3); }

}  // namespace pliant::detail
