// Small text helpers the codecs and the service share: ASCII case folding, trimming, and the media type of a
// Content-Type header (one way to read it everywhere).
#pragma once

#include <string>
#include <string_view>

namespace lipmap::codec {

// ASCII lower case (media types, header names and file extensions are case-insensitive ASCII).
std::string lower(std::string_view s);

// Without leading and trailing white space.
std::string trim(std::string_view s);

// "Model/GLTF-Binary ; charset=x" -> "model/gltf-binary": lower case, parameters and white space dropped.
std::string media_type(std::string_view content_type);

}  // namespace lipmap::codec
