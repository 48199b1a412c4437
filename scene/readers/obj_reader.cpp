#include "scene/readers/obj_reader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "core/paths.h"
#include "core/sha256.h"
#include "core/text.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;

// At most 12 characters of a word radlab did not understand (core/text.h): enough to find a
// misspelt key, too little to disclose a file named by mistake (or on purpose).
std::string shown(std::string_view word) {
  return text::printable_prefix(word, 12);
}

struct LineReader {
  explicit LineReader(const std::string& file) : path(file) {
    // Regular files only: /dev/zero would be one endless line.
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec))
      throw InputError(file + ": not a regular file");
    in.open(file);
    if (!in) throw InputError(file + ": cannot open file");
  }
  bool next(std::string& line) {
    if (!std::getline(in, line)) {
      // A failed read is not the end of the file.
      if (in.bad()) throw InputError(path + ":" + std::to_string(number + 1) + ": read error");
      return false;
    }
    // Hashed as read, newline included unless the file ended without one: the digest is the
    // file's bytes (what `sha256sum` says), of exactly the text parsed.
    hash.update(line);
    if (!in.eof()) hash.update("\n");
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(path + ":" + std::to_string(number) + ": " + message);
  }
  // The file's SourceFile, once every line has been read.
  SourceFile source() { return SourceFile{path, hash.hex()}; }
  std::string path;
  std::ifstream in;
  int number = 0;
  Sha256 hash;
};

Rgb parse_rgb(const LineReader& reader, const std::vector<std::string_view>& tokens) {
  // "Kd r g b" or "Kd v" (grey); the "spectral" and "xyz" forms are not supported.
  if (tokens.size() != 2 && tokens.size() != 4)
    reader.fail("'" + std::string(tokens[0]) + "' needs 1 or 3 numbers, got " +
                std::to_string(tokens.size() - 1));
  Rgb c;
  for (size_t i = 1; i < tokens.size(); ++i) {
    auto v = text::parse_double(tokens[i]);
    if (!v)
      reader.fail("'" + std::string(tokens[0]) + "': '" + shown(tokens[i]) + "' is not a number");
    c[int(i - 1)] = *v;
  }
  if (tokens.size() == 2) c = Rgb(c.x);
  return c;
}

// MTL statements other than newmtl, Kd and Ke that renderers write (Wavefront's MTL
// specification and the PBR extension): read and ignored without a warning.
bool known_mtl_key(std::string_view key) {
  static const std::set<std::string_view> known = {
      "Ka",    "Ks",   "Ns", "Ni", "d",  "Tr", "Tf",  "illum", "sharpness", "bump", "disp",
      "decal", "refl", "Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor",    "norm"};
  return known.count(key) || text::starts_with(key, "map_");
}

// Unknown MTL keys warned about per file; more are ignored silently.
constexpr size_t kMaxUnknownKeys = 8;

void read_mtl(const std::string& path, Scene& scene, std::map<std::string, int>& by_name,
              bool print_warnings) {
  LineReader reader(path);
  std::string line;
  int current = -1;
  std::set<std::string> warned;
  while (reader.next(line)) {
    auto tokens = text::split_whitespace(line);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::string_view key = tokens[0];
    // Anything but a material first: not a material library (a path that named the wrong file);
    // refused without showing what it holds.
    if (current < 0 && key != "newmtl")
      reader.fail("not a material library (its first statement is not 'newmtl')");
    if (key == "newmtl") {
      if (tokens.size() < 2) reader.fail("'newmtl' needs a name");
      std::string name(text::trim(std::string_view(line).substr(line.find("newmtl") + 6)));
      if (by_name.count(name)) reader.fail("material '" + name + "' defined twice");
      scene.materials.push_back(Material{name, Rgb(0.0), Rgb(0.0)});
      current = int(scene.materials.size() - 1);
      by_name[name] = current;
    } else if (key == "Kd" || key == "Ke") {
      Rgb c = parse_rgb(reader, tokens);
      Material& m = scene.materials[size_t(current)];
      (key == "Kd" ? m.reflectance : m.emission) = c;
      // Range checks happen in validate_scene, which names the material; keep the line here too.
      if (key == "Kd" && !(c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1 && c.z >= 0 && c.z <= 1))
        reader.fail("material '" + m.name + "': Kd (reflectance) must lie in [0,1]");
      if (key == "Ke" && !(c.x >= 0 && c.y >= 0 && c.z >= 0 && std::isfinite(c.x) &&
                           std::isfinite(c.y) && std::isfinite(c.z)))
        reader.fail("material '" + m.name + "': Ke (emission) must be finite and >= 0");
    } else if (print_warnings && !known_mtl_key(key) && warned.size() < kMaxUnknownKeys &&
               warned.insert(std::string(key)).second) {
      // Everything else known (Ka, Ks, Ns, Ni, d, Tr, illum, map_*, ...) does not affect
      // diffuse radiosity. An unknown key is most likely a misspelling (MTL keys are
      // case-sensitive: `kd` is not `Kd`, and a material without Kd is black): named, once per
      // key and file.
      log::warning(path + ":" + std::to_string(reader.number) + ": unknown MTL statement '" +
                   shown(key) + "' ignored (keys are case-sensitive; radlab reads Kd and Ke)");
    }
  }
  scene.sources.push_back(reader.source());
}

// The number of face statements ('f' as the first word of a line) in the file: one pass over
// its bytes, nothing stored, so the polygon limit is checked before any face is parsed or
// stored (a 77 MB OBJ of 10^7 faces took 110 s and 4.5 GB before failing).
double count_faces(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file");
  std::vector<char> block(1 << 16);
  double faces = 0;
  // 0: at the start of a line, before its first word; 1: read an 'f' as the first character
  // of the first word; 2: elsewhere in the line.
  int state = 0;
  while (in.read(block.data(), std::streamsize(block.size())) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      const char c = block[size_t(i)];
      if (c == '\n') {
        if (state == 1) ++faces;  // a line that is just "f"
        state = 0;
      } else if (state == 0) {
        if (c == 'f')
          state = 1;
        else if (c != ' ' && c != '\t' && c != '\r')
          state = 2;
      } else if (state == 1) {
        if (c == ' ' || c == '\t' || c == '\r') ++faces;
        state = 2;
      }
    }
  }
  if (in.bad()) throw InputError(path + ": read error");
  if (state == 1) ++faces;
  return faces;
}

}  // namespace

namespace {

// One OBJ file read statement by statement into a Scene: positions, faces, the current
// material, and the material libraries (confined to `root`).
class ObjParser {
 public:
  ObjParser(const std::string& path, const ObjOptions& options)
      : path_(path), options_(options), reader_(path), folder_(fs::path(path).parent_path()) {
    scene_.name = path;
  }

  Scene run() {
    std::error_code ec;
    const fs::path given_root =
        options_.include_root.empty() ? folder_ : fs::path(options_.include_root);
    root_ = fs::weakly_canonical(given_root.empty() ? fs::path(".") : given_root, ec);
    if (ec) throw InputError(given_root.string() + ": cannot resolve the material library folder");
    static const std::set<std::string_view> ignored = {"vt", "vn", "vp", "o",      "g",  "s",
                                                       "l",  "p",  "mg", "cstype", "deg"};
    std::string line;
    while (reader_.next(line)) {
      const auto tokens = text::split_whitespace(line);
      if (tokens.empty() || tokens[0].front() == '#') continue;
      const std::string_view key = tokens[0];
      if (key == "v")
        vertex(tokens);
      else if (key == "f")
        face(tokens);
      else if (key == "usemtl")
        use_material(line, tokens);
      else if (key == "mtllib")
        material_libraries(tokens);
      else if (!ignored.count(key))
        reader_.fail("unknown statement '" + std::string(key).substr(0, 24) + "'");
    }
    if (scene_.polygons.empty()) throw InputError(path_ + ": no faces ('f' lines) in the file");
    // The OBJ first, then its material libraries in the order they were read.
    // (push_back and rotate: GCC 12 sees a null dereference that is not there in an insert at
    // the front of this vector.)
    scene_.sources.push_back(reader_.source());
    std::rotate(scene_.sources.begin(), scene_.sources.end() - 1, scene_.sources.end());
    return std::move(scene_);
  }

 private:
  using Tokens = std::vector<std::string_view>;

  void vertex(const Tokens& tokens) {
    if (tokens.size() < 4 || tokens.size() > 5) reader_.fail("'v' needs 3 coordinates");
    Vec3 p;
    for (int i = 0; i < 3; ++i) {
      auto v = text::parse_double(tokens[size_t(i + 1)]);
      if (!v || !std::isfinite(*v))
        reader_.fail("'v': '" + std::string(tokens[size_t(i + 1)]) + "' is not a finite number");
      p[i] = *v;
    }
    positions_.push_back(p);
  }

  void face(const Tokens& tokens) {
    if (tokens.size() < 4) reader_.fail("'f' needs at least 3 vertices");
    Polygon polygon;
    for (size_t i = 1; i < tokens.size(); ++i) {
      std::string_view ref = tokens[i].substr(0, tokens[i].find('/'));
      auto index = text::parse_int(ref);
      if (!index || *index == 0)
        reader_.fail("'f': '" + std::string(tokens[i]) + "' is not a vertex reference");
      const auto count = static_cast<long long>(positions_.size());
      long long k = *index > 0 ? *index - 1 : count + *index;
      if (k < 0 || k >= count)
        reader_.fail("'f': vertex " + std::to_string(*index) + " does not exist (" +
                     std::to_string(positions_.size()) + " vertices so far)");
      polygon.vertices.push_back(positions_[size_t(k)]);
    }
    if (current_ < 0) {
      if (default_material_ < 0) {
        scene_.materials.push_back(Material{"(default)", Rgb(0.5), Rgb(0.0)});
        default_material_ = int(scene_.materials.size() - 1);
        log::warning(path_ + ":" + std::to_string(reader_.number) +
                     ": face without 'usemtl': using a grey reflectance 0.5, no emission");
      }
      current_ = default_material_;
    }
    polygon.material = current_;
    polygon.origin = path_ + ":" + std::to_string(reader_.number);
    scene_.polygons.push_back(std::move(polygon));
  }

  void use_material(const std::string& line, const Tokens& tokens) {
    if (tokens.size() < 2) reader_.fail("'usemtl' needs a material name");
    std::string name(text::trim(std::string_view(line).substr(line.find("usemtl") + 6)));
    auto it = by_name_.find(name);
    if (it == by_name_.end())
      reader_.fail("'usemtl': material '" + name + "' is not defined by any 'mtllib' before it");
    current_ = it->second;
  }

  void material_libraries(const Tokens& tokens) {
    if (tokens.size() < 2) reader_.fail("'mtllib' needs a file name");
    std::error_code ec;
    for (size_t i = 1; i < tokens.size(); ++i) {
      // An absolute name replaces the folder (operator/): confined like a relative one.
      const fs::path lib = folder_ / std::string(tokens[i]);
      if (!fs::is_regular_file(lib, ec))
        reader_.fail("'mtllib': material library '" + lib.string() +
                     "' not found (or not a regular file)");
      if (!path_within(fs::weakly_canonical(lib, ec), root_))
        reader_.fail("'mtllib': '" + lib.lexically_normal().string() +
                     "' lies outside the scene's folder " + root_.string() +
                     " (to read it, name a folder that holds both with --mgf-include-root DIR)");
      read_mtl(lib.string(), scene_, by_name_, options_.print_warnings);
    }
  }

  const std::string& path_;
  const ObjOptions& options_;
  LineReader reader_;
  fs::path folder_, root_;
  Scene scene_;
  std::map<std::string, int> by_name_;
  std::vector<Vec3> positions_;
  int current_ = -1;           // the material of the faces that follow
  int default_material_ = -1;  // made at the first face without 'usemtl'
};

}  // namespace

Scene read_obj(const std::string& path, const ObjOptions& options) {
  ObjParser parser(path, options);  // opens the file: refuses what is not a regular file first
  check_limit("polygons", count_faces(path), path + ": the OBJ's faces ('f' lines)");
  return parser.run();
}

}  // namespace radlab
