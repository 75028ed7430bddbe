// Writes an RGBA8 image as PNG (libpng). Returns an error message, empty on success.
#pragma once
#include <string>
#include "iris/types.h"
std::string writePng(const std::string& path, const iris::Image& image);
