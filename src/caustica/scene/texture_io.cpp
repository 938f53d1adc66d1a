// Image textures for scenes: decoding (stb_image for PNG/JPEG/BMP/TGA/HDR, libwebp for WebP,
// OpenEXR and PFM through film/image_io) into linear RGBA floats, with a
// per-scene cache so one file is decoded once per (path, colour space).
#include <stb/stb_image.h>
#include <webp/decode.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "../base/error.h"
#include "../film/image_io.h"
#include "scene_desc.h"

namespace caustica {

float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

namespace {

std::string lower_ext(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  for (char& ch : e) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return e;
}

int find_cached(const SceneDesc& d, const std::string& key, bool srgb) {
  for (size_t i = 0; i < d.textures.size(); ++i)
    if (d.textures[i].name == key && d.textures[i].srgb == srgb) return int(i);
  return -1;
}

// Decoded pixels (8-bit from stb_image or libwebp, or float) into linear RGBA.
TextureDesc decoded_texture(const std::string& name, int w, int h, int n, const unsigned char* px8, const float* pxf,
                            bool srgb) {
  TextureDesc t;
  t.name = name;
  t.width = w;
  t.height = h;
  t.srgb = srgb;
  t.rgba.resize(size_t(w) * h * 4);
  float lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = srgb ? srgb_to_linear(i / 255.f) : i / 255.f;
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    float c[4] = {0.f, 0.f, 0.f, 1.f};
    for (int k = 0; k < n; ++k) {
      if (px8) c[k] = k == 3 ? px8[i * n + k] / 255.f : lut[px8[i * n + k]];
      else c[k] = pxf[i * n + k];  // HDR files are linear already
    }
    if (n == 1 || n == 2) {  // grey (+ alpha)
      if (n == 2) c[3] = px8 ? px8[i * n + 1] / 255.f : pxf[i * n + 1];
      c[1] = c[2] = c[0];
    }
    for (int k = 0; k < 4; ++k) t.rgba[i * 4 + k] = c[k];
  }
  return t;
}

// A WebP file: "RIFF", its size, "WEBP".
bool is_webp(const unsigned char* bytes, size_t size) {
  return size >= 12 && std::memcmp(bytes, "RIFF", 4) == 0 && std::memcmp(bytes + 8, "WEBP", 4) == 0;
}

// Decodes a WebP image (lossy or lossless, with or without alpha) into linear RGBA.
TextureDesc from_webp(const std::string& name, const unsigned char* bytes, size_t size, bool srgb,
                      const std::string& referrer) {
  WebPBitstreamFeatures f;
  if (WebPGetFeatures(bytes, size, &f) != VP8_STATUS_OK)
    throw InputError(referrer + ": cannot decode image '" + name + "': not a valid WebP image");
  if (f.has_animation)
    throw InputError(referrer + ": cannot decode image '" + name + "': animated WebP images are not supported");
  int w = 0, h = 0;
  uint8_t* px = f.has_alpha ? WebPDecodeRGBA(bytes, size, &w, &h) : WebPDecodeRGB(bytes, size, &w, &h);
  if (!px) throw InputError(referrer + ": cannot decode image '" + name + "': corrupt WebP data");
  TextureDesc t = decoded_texture(name, w, h, f.has_alpha ? 4 : 3, px, nullptr, srgb);
  WebPFree(px);
  return t;
}

}  // namespace

bool texture_has_alpha(const TextureDesc& t) {
  for (size_t i = 3; i < t.rgba.size(); i += 4)
    if (t.rgba[i] < 1.f) return true;
  return false;
}

int load_texture(SceneDesc& d, const std::string& path, bool srgb, const std::string& referrer) {
  int hit = find_cached(d, path, srgb);
  if (hit >= 0) return hit;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError(referrer + ": texture file '" + path + "' does not exist");
  std::string ext = lower_ext(path);
  if (ext == ".exr" || ext == ".pfm") {
    int w = 0, h = 0;
    std::vector<float> rgb = read_image(path, w, h);  // linear; the srgb flag does not apply
    TextureDesc t;
    t.name = path;
    t.width = w;
    t.height = h;
    t.srgb = srgb;
    t.rgba.resize(size_t(w) * h * 4);
    for (size_t i = 0; i < size_t(w) * h; ++i) {
      for (int k = 0; k < 3; ++k) t.rgba[i * 4 + k] = rgb[i * 3 + k];
      t.rgba[i * 4 + 3] = 1.f;
    }
    d.textures.push_back(std::move(t));
    return int(d.textures.size()) - 1;
  }
  int w = 0, h = 0, n = 0;
  TextureDesc t;
  if (ext == ".webp") {
    std::ifstream f(path, std::ios::binary);
    const std::vector<unsigned char> bytes{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
    if (!f.good() && !f.eof()) throw InputError(referrer + ": cannot read texture '" + path + "'");
    t = from_webp(path, bytes.data(), bytes.size(), srgb, referrer);
  } else if (stbi_is_hdr(path.c_str())) {
    float* px = stbi_loadf(path.c_str(), &w, &h, &n, 0);
    if (!px) throw InputError(referrer + ": cannot read texture '" + path + "': " + stbi_failure_reason());
    t = decoded_texture(path, w, h, n, nullptr, px, srgb);
    stbi_image_free(px);
  } else {
    unsigned char* px = stbi_load(path.c_str(), &w, &h, &n, 0);
    if (!px) throw InputError(referrer + ": cannot read texture '" + path + "': " + stbi_failure_reason());
    t = decoded_texture(path, w, h, n, px, nullptr, srgb);
    stbi_image_free(px);
  }
  d.textures.push_back(std::move(t));
  return int(d.textures.size()) - 1;
}

int load_texture_from_memory(SceneDesc& d, const std::string& name, const unsigned char* bytes, size_t size,
                             bool srgb, const std::string& referrer) {
  int hit = find_cached(d, name, srgb);
  if (hit >= 0) return hit;
  int w = 0, h = 0, n = 0;
  TextureDesc t;
  if (is_webp(bytes, size)) {
    t = from_webp(name, bytes, size, srgb, referrer);
  } else if (stbi_is_hdr_from_memory(bytes, int(size))) {
    float* px = stbi_loadf_from_memory(bytes, int(size), &w, &h, &n, 0);
    if (!px) throw InputError(referrer + ": cannot decode image '" + name + "': " + stbi_failure_reason());
    t = decoded_texture(name, w, h, n, nullptr, px, srgb);
    stbi_image_free(px);
  } else {
    unsigned char* px = stbi_load_from_memory(bytes, int(size), &w, &h, &n, 0);
    if (!px) throw InputError(referrer + ": cannot decode image '" + name + "': " + stbi_failure_reason());
    t = decoded_texture(name, w, h, n, px, nullptr, srgb);
    stbi_image_free(px);
  }
  d.textures.push_back(std::move(t));
  return int(d.textures.size()) - 1;
}

}  // namespace caustica
