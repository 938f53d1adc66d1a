// Writing images: OpenEXR (linear 32-bit float RGB), PFM (linear float), PNG
// (8-bit sRGB after exposure scaling, clamped). Every writer goes to a
// temporary file beside the target and renames it into place, so a target is
// either the old file or the complete new one, never a truncated file.
#pragma once
#include <string>
#include <vector>

namespace caustica {

// The formats by extension: ".exr", ".pfm", ".png".
bool is_supported_image_extension(const std::string& path);
// Throws InputError with one line naming the path and the reason.
void write_image(const std::string& path, const std::vector<float>& rgb, int width, int height,
                 float exposure = 0.f);
// Reads an image written by write_image (EXR or PFM) back as linear RGB.
std::vector<float> read_image(const std::string& path, int& width, int& height);

}  // namespace caustica
