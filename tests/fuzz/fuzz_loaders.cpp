// A seeded mutation fuzzer for the scene loaders (JSON, OBJ+MTL, PLY, glTF,
// GLB, Mitsuba XML), built with AddressSanitizer and UBSan (make fuzz).
//
// Each iteration takes a file of the seed corpus, applies a few random
// mutations (bit flips, interesting bytes, deleted/duplicated/inserted ranges,
// numbers replaced by extreme values, splices with another corpus file),
// writes it beside copies of the corpus (so relative references to .mtl, .bin
// and image files still resolve; a Mitsuba serialized mesh through a small XML scene) and loads it with
// load_scene_desc and
// Scene::build. The only acceptable outcomes are a scene or an InputError
// (the one-line message users see). Any other exception, and anything the
// sanitizers report, is a finding: the input is saved to the findings folder
// and the program exits with status 1.
//
// usage: caustica_fuzz CORPUS_DIR SECONDS [SEED] [FINDINGS_DIR]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/scene/load.h"
#include "caustica/scene/scene.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

namespace fs = std::filesystem;
using namespace caustica;

namespace {

// What the sanitizers' death callback saves: the input being loaded.
fs::path g_current_input, g_findings;
uint64_t g_seed = 0;
long g_iteration = 0;
void save_current_input() {
  if (g_current_input.empty()) return;
  std::error_code ec;
  fs::create_directories(g_findings, ec);
  fs::path out = g_findings / ("crash-" + std::to_string(g_seed) + "-" + std::to_string(g_iteration) +
                               g_current_input.extension().string());
  fs::copy_file(g_current_input, out, fs::copy_options::overwrite_existing, ec);
  std::fprintf(stderr, "fuzz: the input that crashed is saved as %s\n", out.c_str());
}

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}
void write_file(const fs::path& p, const std::string& s) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(s.data(), std::streamsize(s.size()));
}

bool is_scene_file(const fs::path& p) {
  std::string e = p.extension().string();
  return e == ".json" || e == ".obj" || e == ".ply" || e == ".gltf" || e == ".glb" || e == ".xml" ||
         e == ".serialized";
}

// The file to load for a seed or its mutation: the file itself, or for a Mitsuba serialized mesh (not a scene on
// its own) a Mitsuba XML scene beside it that loads its second mesh, written once.
fs::path loadable(const fs::path& file) {
  if (file.extension() != ".serialized") return file;
  fs::path xml = file;
  xml += ".xml";
  if (!fs::exists(xml))
    write_file(xml, "<scene version=\"3.0.0\"><shape type=\"serialized\"><string name=\"filename\" value=\"" +
                        file.filename().string() + "\"/><integer name=\"shape_index\" value=\"1\"/></shape></scene>\n");
  return xml;
}

struct Mutator {
  PCG32 rng;
  const std::vector<std::string>* pool;

  uint32_t below(uint32_t n) { return n ? rng.next_u32() % n : 0; }

  void mutate(std::string& s) {
    static const char kBytes[] = {'\0', '\xff', '-', '9', '.', 'e', ' ', '\n', '[', ']', '{', '}', '"', '<', '>',
                                  '/', '#', '0', '\x7f', '\x80'};
    static const char* kNumbers[] = {"nan", "-nan", "inf", "-1", "0", "1e38", "-1e38", "4294967295", "2147483648",
                                     "-2147483649", "1e-45", "99999999999999999999", "0.0", "3"};
    int n = 1 + int(below(8));
    for (int k = 0; k < n; ++k) {
      if (s.empty()) s = "x";
      uint32_t pos = below(uint32_t(s.size()));
      switch (below(8)) {
        case 0: s[pos] = char(s[pos] ^ (1u << below(8))); break;
        case 1: s[pos] = kBytes[below(sizeof kBytes)]; break;
        case 2: s.erase(pos, 1 + below(std::min<uint32_t>(64, uint32_t(s.size()) - pos))); break;
        case 3: {  // duplicate a range
          uint32_t len = 1 + below(std::min<uint32_t>(256, uint32_t(s.size()) - pos));
          s.insert(below(uint32_t(s.size())), s.substr(pos, len));
          break;
        }
        case 4: {  // random bytes
          std::string r(1 + below(16), '\0');
          for (char& c : r) c = char(below(256));
          s.insert(pos, r);
          break;
        }
        case 5: {  // replace the number at pos (if any) by an extreme value
          size_t a = pos;
          while (a > 0 && (std::isdigit(static_cast<unsigned char>(s[a - 1])) || s[a - 1] == '.')) --a;
          size_t b = pos;
          while (b < s.size() && (std::isdigit(static_cast<unsigned char>(s[b])) || s[b] == '.')) ++b;
          s.replace(a, b - a, kNumbers[below(sizeof kNumbers / sizeof *kNumbers)]);
          break;
        }
        case 6: {  // splice: the head of this file and the tail of another
          const std::string& o = (*pool)[below(uint32_t(pool->size()))];
          if (!o.empty()) s = s.substr(0, pos) + o.substr(below(uint32_t(o.size())));
          break;
        }
        default: s.resize(pos); break;  // truncate
      }
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR SECONDS [SEED] [FINDINGS_DIR]\n", argv[0]);
    return 2;
  }
  fs::path corpus = argv[1];
  double seconds = std::atof(argv[2]);
  uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1;
  fs::path findings = argc > 4 ? fs::path(argv[4]) : fs::path("fuzz-findings");
  g_findings = findings;
  g_seed = seed;
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_set_death_callback(save_current_input);
#endif

  // Work in a private copy of the corpus so companion files resolve.
  fs::path work = fs::temp_directory_path() / ("caustica-fuzz-" + std::to_string(seed));
  fs::remove_all(work);
  fs::create_directories(work);
  std::vector<fs::path> seeds;
  std::vector<std::string> contents;
  for (const auto& e : fs::recursive_directory_iterator(corpus)) {
    if (!e.is_regular_file()) continue;
    fs::path rel = fs::relative(e.path(), corpus);
    fs::create_directories((work / rel).parent_path());
    fs::copy_file(e.path(), work / rel, fs::copy_options::overwrite_existing);
    if (is_scene_file(e.path())) {
      seeds.push_back(rel);
      contents.push_back(read_file(e.path()));
    }
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "fuzz: no scene files in %s\n", corpus.c_str());
    return 2;
  }
  std::sort(seeds.begin(), seeds.end());
  contents.clear();
  for (const fs::path& p : seeds) contents.push_back(read_file(corpus / p));

  // A loader that hangs is a finding too: the watchdog aborts after 20 s on one input.
  std::atomic<long> current{-1};
  std::atomic<bool> stop{false};
  fs::path current_file;
  std::thread watchdog([&]() {
    long last = -2;
    auto since = std::chrono::steady_clock::now();
    while (!stop.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      long c = current.load();
      auto now = std::chrono::steady_clock::now();
      if (c != last) {
        last = c;
        since = now;
      } else if (c >= 0 && std::chrono::duration<double>(now - since).count() > 20.0) {
        fs::create_directories(findings);
        fs::path out = findings / ("hang-" + std::to_string(seed) + "-" + std::to_string(c) +
                                   current_file.extension().string());
        fs::copy_file(current_file, out, fs::copy_options::overwrite_existing);
        std::fprintf(stderr, "fuzz: %s: a loader ran for more than 20 s on this input\n", out.c_str());
        std::_Exit(1);
      }
    }
  });

  const bool verbose = std::getenv("CAUSTICA_FUZZ_VERBOSE") != nullptr;  // print every rejection
  Mutator mut{PCG32(seed, 0xf022), &contents};
  auto t0 = std::chrono::steady_clock::now();
  long iters = 0, loaded = 0, rejected = 0;
  std::vector<long> per_seed(seeds.size(), 0);
  // Loads and builds a file; a glTF file's first material variant (KHR_materials_variants) too.
  auto load_and_build = [](const std::string& path) {
    SceneDesc d = load_scene_desc(path);
    Scene::build(d);
    if (!d.variants.empty()) {
      LoadOptions o;
      o.variant = d.variants[0];
      Scene::build(load_scene_desc(path, o));
    }
  };
  // The unmutated seeds must load: a corpus that is already broken tests nothing.
  for (size_t i = 0; i < seeds.size(); ++i) {
    try {
      load_and_build(loadable(work / seeds[i]).string());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz: seed %s does not load: %s\n", seeds[i].c_str(), e.what());
      return 1;
    }
  }
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
    size_t i = size_t(iters % long(seeds.size()));
    std::string s = contents[i];
    mut.mutate(s);
    fs::path target = work / seeds[i].parent_path() / ("mut_" + seeds[i].filename().string());
    write_file(target, s);
    current_file = target;
    g_current_input = target;
    g_iteration = iters;
    current.store(iters);
    ++iters;
    ++per_seed[i];
    try {
      load_and_build(loadable(target).string());
      ++loaded;
    } catch (const InputError& e) {
      ++rejected;
      if (verbose) std::printf("%s\n", e.what());
    } catch (const std::exception& e) {
      fs::create_directories(findings);
      fs::path out = findings / ("finding-" + std::to_string(seed) + "-" + std::to_string(iters) +
                                 seeds[i].extension().string());
      write_file(out, s);
      std::fprintf(stderr, "fuzz: %s (from %s): not an InputError: %s\n", out.c_str(), seeds[i].c_str(), e.what());
      std::_Exit(1);
    }
  }
  current.store(-1);
  g_current_input.clear();
  stop.store(true);
  watchdog.join();
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("fuzz: %ld inputs in %.0f s (seed %llu): %ld loaded, %ld rejected with a message, 0 findings\n", iters,
              secs, (unsigned long long)seed, loaded, rejected);
  for (size_t i = 0; i < seeds.size(); ++i) std::printf("  %-28s %ld inputs\n", seeds[i].c_str(), per_seed[i]);
  fs::remove_all(work);
  return 0;
}
