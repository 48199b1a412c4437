#include "scene/readers/mgf_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <sstream>
#include <unordered_map>

#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "core/paths.h"
#include "core/sha256.h"
#include "core/text.h"
#include "scene/cie_colour.h"
#include "scene/geometry.h"
#include "scene/tessellate.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;

// Includes nested deeper than this are taken for a cycle.
constexpr int kMaxIncludeDepth = 32;
// File inclusions in all (each execution of an `i`, arrays and repeats included). Nesting
// multiplies them: 32 files each including the next twice are 2^31 inclusions. The RenderPark
// hospital, the largest real scene here, makes 71.
constexpr long kMaxIncludes = 10000;
// Statements executed per polygon allowed (arrays and includes repeat statements; a body that
// makes no polygon still costs time): the work bound is this times limits().polygons.
constexpr double kStatementsPerPolygon = 4.0;

// A word from the file as quoted in a message: at most 24 characters (core/text.h).
std::string quoted(const std::string& word) {
  return text::printable_prefix(word, 24);
}
// Chromaticities this close to (1/3, 1/3) are MGF's neutral: the files write 0.333 or 0.3330 for
// it, and the difference (below the precision they carry) would otherwise make every grey
// material very slightly coloured and the whole scene need three channels instead of one.
constexpr double kNeutralTolerance = 5e-4;

// One logical line (continuations joined): its first physical line and its words.
struct Statement {
  int line = 0;
  std::vector<std::string> words;
};

struct ParsedFile {
  std::string path;  // as given or resolved, for messages
  fs::path folder;   // includes are relative to it
  std::vector<Statement> statements;
};

// An MGF colour is a chromaticity; luminance comes with the rd/ed/... that uses it.
struct Colour {
  cie::Chromaticity xy{1.0 / 3.0, 1.0 / 3.0};
  // A spectrum with no positive luminance (e.g. the CIE daylight basis functions S1, S2 in
  // Materials/illums.mgf, which go negative) has no chromaticity: defining it is fine, using it
  // for rd/ed/cmix is an error naming this line.
  std::string undefined_at;  // "file:line" of that definition, empty when usable
};

struct MaterialState {
  std::string name;  // empty: the unnamed material
  double rd = 0.0;
  Colour rd_colour;
  double ed = 0.0;
  Colour ed_colour;
  // Read and checked, not used by diffuse radiosity (docs/scenes.md).
  double td = 0.0, rs = 0.0, ts = 0.0;
  int sides = 2;  // MGF's default material is a two-sided black absorber
  long version = 0;
  // The Scene material made from this state, valid while scene_version == version.
  int scene_index = -1;
  long scene_version = -1;
  int conversions = 0;
};

struct VertexState {
  Vec3 p{0.0};
  Vec3 n{0.0};  // zero: no normal
};

struct XfContext {
  glm::dmat4 m{1.0};
  bool flips = false;  // negative determinant: reverse windings to keep front sides
};

// The arguments of one `xf` (or of an `i` with a transform): a leading group of plain
// arguments, then groups opened by -a N (an array: instance k applies the group k times) or by
// -i N (applies the group N times).
struct XfGroup {
  glm::dmat4 m{1.0};
  int count = 1;
  bool array = false;
};

// m^k by repeated squaring (k <= 1e6: at most 40 products).
glm::dmat4 power(glm::dmat4 m, int k) {
  glm::dmat4 out(1.0);
  for (; k > 0; k >>= 1) {
    if (k & 1) out = m * out;
    m = m * m;
  }
  return out;
}

class Reader {
 public:
  Reader(const MgfOptions& options, MgfStats& stats) : options_(options), stats_(stats) {
    segments_ = 4 * options.quarter_circle_divisions;
    transforms_.push_back(XfContext{});
    current_vertex_ = &scratch_vertex_;
    current_colour_ = &scratch_colour_;
    current_material_ = &scratch_material_;
  }

  Scene read(const std::string& path) {
    if (options_.quarter_circle_divisions < 1 || options_.quarter_circle_divisions > 64)
      throw InputError(path + ": MGF quarter_circle_divisions must lie in [1, 64], got " +
                       std::to_string(options_.quarter_circle_divisions));
    std::error_code ec;
    const fs::path root = options_.include_root.empty() ? fs::path(path).parent_path()
                                                        : fs::path(options_.include_root);
    root_ = fs::weakly_canonical(root.empty() ? fs::path(".") : root, ec);
    if (ec) throw InputError(root.string() + ": cannot resolve the MGF include folder");
    max_statements_ = kStatementsPerPolygon * limits().polygons;
    const ParsedFile& file = load(fs::path(path), path);
    run_file(file);
    if (scene_.polygons.empty())
      throw InputError(path + ": no geometry (no f, sph, cyl, cone, ring, torus or prism)");
    scene_.name = path;
    return std::move(scene_);
  }

 private:
  // ---- files ------------------------------------------------------------------------------

  const ParsedFile& load(const fs::path& path, const std::string& shown) {
    std::error_code ec;
    fs::path key = fs::weakly_canonical(path, ec);
    if (ec) key = path;
    auto it = files_.find(key.string());
    if (it != files_.end()) return *it->second;
    // Regular files only: /dev/zero or a FIFO would be read until memory runs out.
    if (fs::exists(path, ec) && !fs::is_regular_file(path, ec))
      throw InputError(shown + ": not a regular file (MGF reads and includes only regular files)" +
                       include_chain());
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(shown + ": cannot open file" + include_chain());
    std::string text;
    char chunk[1 << 16];
    while (in.read(chunk, sizeof chunk) || in.gcount() > 0) text.append(chunk, size_t(in.gcount()));
    // A failed read is not the end of the file.
    if (in.bad()) throw InputError(shown + ": read error" + include_chain());
    // The digest of exactly the bytes parsed: a sweep's identity (Scene::sources).
    scene_.sources.push_back(SourceFile{shown, sha256_hex(text)});
    auto file = std::make_unique<ParsedFile>();
    file->path = shown;
    file->folder = path.parent_path();
    std::string logical;
    int first_line = 0, number = 0;
    size_t start = 0;
    while (start <= text.size()) {
      size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      std::string_view line(text.data() + start, end - start);
      ++number;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (logical.empty()) first_line = number;
      const bool continued = !line.empty() && line.back() == '\\';
      if (continued) line.remove_suffix(1);
      logical.append(line);
      logical.push_back(' ');
      if (!continued || end == text.size()) {
        auto words = text::split_whitespace(logical);
        if (!words.empty() && words[0].front() != '#') {
          Statement s;
          s.line = first_line;
          s.words.reserve(words.size());
          for (std::string_view w : words) s.words.emplace_back(w);
          file->statements.push_back(std::move(s));
        }
        logical.clear();
      }
      if (end == text.size()) break;
      start = end + 1;
    }
    ++stats_.files;
    const ParsedFile& ref = *file;
    files_.emplace(key.string(), std::move(file));
    return ref;
  }

  // Runs a whole file; the contexts it opens must be closed by its end.
  void run_file(const ParsedFile& file) {
    const size_t transform_depth = transforms_.size();
    const size_t object_depth = objects_.size();
    frames_.push_back(Frame{&file, transform_depth, object_depth});
    run(file, 0, file.statements.size());
    if (transforms_.size() != transform_depth) {
      const int line = transform_lines_.back();
      throw InputError(file.path + ":" + std::to_string(line) + ": 'xf' context opened here is " +
                       "not closed by the end of the file (MGF contexts must balance per file)" +
                       include_chain());
    }
    if (objects_.size() != object_depth)
      throw InputError(file.path + ":" + std::to_string(objects_.back().second) + ": object '" +
                       objects_.back().first + "' opened here is not closed by the end of the " +
                       "file (MGF contexts must balance per file)" + include_chain());
    frames_.pop_back();
  }

  void run(const ParsedFile& file, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Statement& s = file.statements[i];
      where_ = &s;
      file_ = &file;
      const std::string& key = s.words[0];
      count_statement();
      if (key == "xf" && s.words.size() > 1) {
        std::vector<XfGroup> groups = parse_transform(s, 1);
        if (has_array(groups)) {
          const size_t close = matching_xf(file, i, end);
          // Every instance runs the body at least once: bounded before the first one runs.
          check_work(instance_count(groups) * double(close - i), "the 'xf -a' array");
          for_each_instance(groups, [&](const glm::dmat4& m) {
            push_transform(m, s.line);
            run(file, i + 1, close);
            pop_transform();
            where_ = &s;
            file_ = &file;
          });
          i = close;
        } else {
          for_each_instance(groups, [&](const glm::dmat4& m) { push_transform(m, s.line); });
        }
      } else if (key == "i") {
        include(file, s);
      } else {
        statement(s);
      }
    }
  }

  // The index of the `xf` that closes the one at `open`, within [open + 1, end).
  size_t matching_xf(const ParsedFile& file, size_t open, size_t end) {
    int depth = 1;
    for (size_t j = open + 1; j < end; ++j) {
      const auto& w = file.statements[j].words;
      if (w[0] != "xf") continue;
      depth += w.size() > 1 ? 1 : -1;
      if (depth == 0) return j;
    }
    fail("'xf' array (-a) has no matching 'xf' end in the same file");
  }

  void include(const ParsedFile& file, const Statement& s) {
    if (s.words.size() < 2) fail("'i' needs a file name");
    if (frames_.size() >= size_t(kMaxIncludeDepth))
      fail("includes nested more than " + std::to_string(kMaxIncludeDepth) +
           " deep (does a file include itself?)");
    std::string name = s.words[1];
    fs::path path;
    if (text::starts_with(name, "~/")) {
      const char* home = std::getenv("HOME");
      if (!home) fail("'i " + name + "': '~' needs HOME to be set");
      path = fs::path(home) / name.substr(2);
    } else if (fs::path(name).is_absolute()) {
      path = name;  // not allowed by the MGF standard, accepted here
    } else {
      path = file.folder / name;
    }
    std::vector<XfGroup> groups(1);
    const bool transformed = s.words.size() > 2;
    if (transformed) groups = parse_transform(s, 2);
    if (!fs::exists(path)) fail("'i': included file '" + path.string() + "' not found");
    std::error_code ec;
    if (!path_within(fs::weakly_canonical(path, ec), root_))
      fail("'i': '" + path.lexically_normal().string() + "' lies outside the scene's folder " +
           root_.string() + " (to read it, name a folder that holds both with " +
           "--mgf-include-root DIR)");
    check_work(instance_count(groups), "the included file's instances");
    includes_.push_back(file.path + ":" + std::to_string(s.line));
    const ParsedFile& included = load(path, path.lexically_normal().string());
    for_each_instance(groups, [&](const glm::dmat4& m) {
      if (++include_count_ > kMaxIncludes)
        fail("more than " + std::to_string(kMaxIncludes) +
             " file inclusions (nested includes multiply: does a file include another twice at "
             "every level?)");
      if (transformed) push_transform(m, s.line);
      run_file(included);
      if (transformed) pop_transform();
    });
    includes_.pop_back();
    where_ = &s;
    file_ = &file;
  }

  // ---- transforms -------------------------------------------------------------------------

  std::vector<XfGroup> parse_transform(const Statement& s, size_t first) {
    std::vector<XfGroup> groups(1);
    const auto& w = s.words;
    auto arg = [&](size_t k, const std::string& flag) {
      if (k >= w.size()) fail("'" + flag + "' needs a number");
      return parse_number(w[k], "'" + flag + "'");
    };
    for (size_t k = first; k < w.size(); ++k) {
      const std::string& flag = w[k];
      glm::dmat4& m = groups.back().m;
      if (flag == "-t") {
        const Vec3 t(arg(k + 1, flag), arg(k + 2, flag), arg(k + 3, flag));
        m = glm::translate(glm::dmat4(1.0), t) * m;
        k += 3;
      } else if (flag == "-rx" || flag == "-ry" || flag == "-rz") {
        Vec3 axis(0.0);
        axis[flag[2] - 'x'] = 1.0;
        const double degrees = arg(k + 1, flag);
        m = glm::rotate(glm::dmat4(1.0), degrees * std::numbers::pi / 180.0, axis) * m;
        k += 1;
      } else if (flag == "-s") {
        const double f = arg(k + 1, flag);
        if (f == 0.0) fail("'-s': the scale factor must not be zero");
        m = glm::scale(glm::dmat4(1.0), Vec3(f)) * m;
        k += 1;
      } else if (flag == "-mx" || flag == "-my" || flag == "-mz") {
        Vec3 f(1.0);
        f[flag[2] - 'x'] = -1.0;
        m = glm::scale(glm::dmat4(1.0), f) * m;
      } else if (flag == "-a" || flag == "-i") {
        const double n = arg(k + 1, flag);
        if (!(n >= 1 && n == std::floor(n) && n <= 1e6))
          fail("'" + flag + "' needs a whole number >= 1, got '" + w[k + 1] + "'");
        groups.push_back(XfGroup{glm::dmat4(1.0), static_cast<int>(n), flag == "-a"});
        k += 1;
      } else {
        fail("unknown transform argument '" + quoted(flag) +
             "' (MGF has -t, -rx, -ry, -rz, -s, -mx, -my, -mz, -i, -a)");
      }
    }
    return groups;
  }

  static bool has_array(const std::vector<XfGroup>& groups) {
    return std::any_of(groups.begin(), groups.end(), [](const XfGroup& g) { return g.array; });
  }

  // Instances of a transform: the product of its array counts (1 without arrays), in double.
  static double instance_count(const std::vector<XfGroup>& groups) {
    double total = 1.0;
    for (const XfGroup& g : groups)
      if (g.array) total *= double(g.count);
    return total;
  }

  // Calls fn(local transform) for every instance, the first array's index varying fastest.
  // Incremental: instance k + 1 of an array group is its matrix times instance k (one product),
  // never a list of instances or a power per instance.
  template <class Fn>
  void for_each_instance(const std::vector<XfGroup>& groups, Fn&& fn) {
    std::vector<glm::dmat4> current(groups.size());
    std::vector<int> index(groups.size(), 0);
    std::vector<size_t> arrays;
    for (size_t g = 0; g < groups.size(); ++g) {
      current[g] = groups[g].array ? glm::dmat4(1.0) : power(groups[g].m, groups[g].count);
      if (groups[g].array) arrays.push_back(g);
    }
    for (;;) {
      glm::dmat4 m(1.0);
      for (const glm::dmat4& c : current) m = c * m;
      fn(m);
      size_t k = 0;
      for (; k < arrays.size(); ++k) {
        const size_t a = arrays[k];
        if (++index[a] < groups[a].count) {
          current[a] = groups[a].m * current[a];
          break;
        }
        index[a] = 0;
        current[a] = glm::dmat4(1.0);
      }
      if (k == arrays.size()) return;  // every index wrapped: done
    }
  }

  // The work bound: statements executed (arrays and includes repeat them).
  void count_statement() {
    if (++statements_ > max_statements_)
      check_work(0.0, "the scene (arrays and includes repeat statements)");
  }
  void check_work(double statements, const std::string& what) {
    if (statements + statements_ <= max_statements_) return;
    fail(what + " would execute " + format_count(statements + statements_) +
         " MGF statements, above " + format_count(max_statements_) + " (" +
         format_count(kStatementsPerPolygon) + " per polygon of the limit; raise it with " +
         "--limits polygons=N if this machine can afford it)");
  }

  void push_transform(const glm::dmat4& local, int line) {
    XfContext c;
    c.m = transforms_.back().m * local;
    c.flips = glm::determinant(glm::dmat3(c.m)) < 0.0;
    transforms_.push_back(c);
    transform_lines_.push_back(line);
  }

  void pop_transform() {
    transforms_.pop_back();
    transform_lines_.pop_back();
  }

  // ---- entities ---------------------------------------------------------------------------

  void statement(const Statement& s) {
    const std::string& key = s.words[0];
    const size_t n = s.words.size() - 1;  // arguments
    if (key == "xf") {                    // a bare xf: pop
      if (transforms_.size() <= frames_.back().transform_depth)
        fail("'xf' end without a matching 'xf' in this file");
      pop_transform();
    } else if (key == "o") {
      if (n == 0) {
        if (objects_.size() <= frames_.back().object_depth)
          fail("'o' end without a matching 'o name' in this file");
        objects_.pop_back();
      } else {
        objects_.emplace_back(s.words[1], s.line);
      }
    } else if (key == "v") {
      vertex_context(s);
    } else if (key == "p" || key == "n") {
      expect(n == 3, "'" + key + "' needs 3 numbers");
      Vec3 value(number(1), number(2), number(3));
      if (key == "p") {
        current_vertex_->p = value;
      } else {
        const double length = glm::length(value);
        current_vertex_->n = length > 0 ? value / length : Vec3(0.0);
      }
    } else if (key == "c") {
      colour_context(s);
    } else if (key == "cxy") {
      expect(n == 2, "'cxy' needs 2 numbers (x y)");
      const double x = number(1), y = number(2);
      if (!(x >= 0 && y >= 0 && x + y <= 1))
        fail("'cxy': (" + s.words[1] + ", " + s.words[2] +
             ") is not a chromaticity (x >= 0, y >= 0, x + y <= 1)");
      current_colour_->xy = {x, y};
      current_colour_->undefined_at.clear();
    } else if (key == "cspec") {
      expect(n >= 4, "'cspec' needs lambda_min lambda_max and at least 2 values");
      const double lmin = number(1), lmax = number(2);
      if (!(lmin < lmax && lmin > 0)) fail("'cspec': need 0 < lambda_min < lambda_max");
      std::vector<double> values;
      for (size_t k = 3; k <= n; ++k) values.push_back(number(k));
      set_colour(cie::spectrum_to_xyz(lmin, lmax, values));
    } else if (key == "cct") {
      expect(n == 1, "'cct' needs a temperature");
      const double kelvin = number(1);
      if (!(kelvin >= 500 && kelvin <= 1e6)) fail("'cct': temperature must lie in [500, 1e6] K");
      set_colour(cie::blackbody_to_xyz(kelvin));
    } else if (key == "cmix") {
      expect(n >= 2 && n % 2 == 0, "'cmix' needs pairs of weight and colour name");
      // Weights are luminances (MGF's illums.mgf: weights proportional to the relative
      // luminance each named colour contributes): mix XYZ of each colour at Y = weight.
      cie::Xyz sum(0.0);
      for (size_t k = 1; k < n; k += 2) {
        const double weight = number(k);
        if (weight < 0) fail("'cmix': weights must be >= 0");
        auto it = colours_.find(s.words[k + 1]);
        if (it == colours_.end()) fail("'cmix': colour '" + s.words[k + 1] + "' is not defined");
        sum += cie::xyY_to_xyz(usable(it->second, "'cmix'").xy, weight);
      }
      set_colour(sum);
    } else if (key == "m") {
      material_context(s);
    } else if (key == "rd" || key == "td" || key == "ed") {
      expect(n == 1, "'" + key + "' needs 1 number");
      const double value = number(1);
      MaterialState& m = *current_material_;
      if (key == "ed") {
        if (!(value >= 0) || std::isinf(value)) fail("'ed' must be finite and >= 0");
        m.ed = value;
        m.ed_colour = value > 0 ? usable(*current_colour_, "'ed'") : Colour{};
      } else {
        if (!(value >= 0 && value <= 1)) fail("'" + key + "' must lie in [0, 1]");
        (key == "rd" ? m.rd : m.td) = value;
        if (key == "rd") m.rd_colour = value > 0 ? usable(*current_colour_, "'rd'") : Colour{};
      }
      ++m.version;
    } else if (key == "rs" || key == "ts") {
      expect(n == 2, "'" + key + "' needs 2 numbers (reflectance/transmittance, roughness)");
      const double value = number(1), roughness = number(2);
      if (!(value >= 0 && value <= 1)) fail("'" + key + "' must lie in [0, 1]");
      if (!(roughness >= 0)) fail("'" + key + "': roughness must be >= 0");
      (key == "rs" ? current_material_->rs : current_material_->ts) = value;
      ++current_material_->version;
    } else if (key == "ir") {
      expect(n == 2, "'ir' needs 2 numbers (real and imaginary index of refraction)");
      number(1);
      number(2);
    } else if (key == "sides") {
      expect(n == 1 && (s.words[1] == "1" || s.words[1] == "2"), "'sides' must be 1 or 2");
      current_material_->sides = s.words[1] == "1" ? 1 : 2;
      ++current_material_->version;
    } else if (key == "f") {
      expect(n >= 3, "'f' needs at least 3 vertices");
      std::vector<Vec3> polygon;
      polygon.reserve(n);
      for (size_t k = 1; k <= n; ++k) polygon.push_back(vertex(s.words[k]).p);
      ++stats_.faces;
      emit(std::move(polygon));
    } else if (key == "sph") {
      expect(n == 2, "'sph' needs a centre vertex and a radius");
      sphere(vertex(s.words[1]).p, number(2));
    } else if (key == "cyl") {
      expect(n == 3, "'cyl' needs vertex radius vertex");
      const double r = number(2);
      if (r == 0) fail("'cyl': the radius must not be zero");
      ++stats_.cylinders;
      cone(vertex(s.words[1]).p, r, vertex(s.words[3]).p, r);
    } else if (key == "cone") {
      expect(n == 4, "'cone' needs vertex radius vertex radius");
      const double r1 = number(2), r2 = number(4);
      if (r1 == 0 && r2 == 0) fail("'cone': at most one radius may be zero");
      if ((r1 < 0 && r2 > 0) || (r1 > 0 && r2 < 0)) fail("'cone': the radii's signs disagree");
      ++stats_.cones;
      cone(vertex(s.words[1]).p, r1, vertex(s.words[3]).p, r2);
    } else if (key == "ring") {
      expect(n == 3, "'ring' needs a centre vertex and two radii");
      ring(vertex(s.words[1]), number(2), number(3));
    } else if (key == "torus") {
      expect(n == 3, "'torus' needs a centre vertex and two radii");
      torus(vertex(s.words[1]), number(2), number(3));
    } else if (key == "prism") {
      expect(n >= 4, "'prism' needs at least 3 vertices and a length");
      std::vector<Vec3> base;
      for (size_t k = 1; k < n; ++k) base.push_back(vertex(s.words[k]).p);
      prism(base, number(n));
    } else if (key == "ies") {
      if (warn("'ies' luminaire '" + (n > 0 ? s.words[1] : std::string()) +
               "' ignored: radlab does not read IES photometry, so its light is missing"))
        ++stats_.ignored_lines;
    } else if (key == "fh") {
      fail("'fh' (face with holes) is not supported; express the face as convex polygons");
    } else if (std::isalpha(static_cast<unsigned char>(key[0]))) {
      fail("unknown entity '" + quoted(key) + "'");
    } else {
      // Not an entity at all: MGF keywords begin with a letter. office1/graz.mgf has three such
      // lines (paths left over from a mail header). MGF's own parser skips unknown entities with
      // a warning; radlab does that only for words that cannot be entities, and rejects the rest.
      if (warn("'" + quoted(key) +
               "' is not an MGF entity (keywords begin with a letter); line skipped"))
        ++stats_.ignored_lines;
    }
  }

  void vertex_context(const Statement& s) {
    const auto& w = s.words;
    if (w.size() == 1) {
      scratch_vertex_ = VertexState{};
      current_vertex_ = &scratch_vertex_;
    } else if (w.size() == 2) {
      current_vertex_ = &vertex(w[1]);
    } else {
      expect(w[2] == "=" && w.size() <= 4, "'v' takes: v | v name | v name = | v name = template");
      VertexState value;
      if (w.size() == 4) value = vertex(w[3]);
      VertexState& v = vertices_[w[1]];
      v = value;
      current_vertex_ = &v;
    }
  }

  void colour_context(const Statement& s) {
    const auto& w = s.words;
    if (w.size() == 1) {
      scratch_colour_ = Colour{};
      current_colour_ = &scratch_colour_;
    } else if (w.size() == 2) {
      auto it = colours_.find(w[1]);
      if (it == colours_.end()) fail("colour '" + w[1] + "' is not defined");
      current_colour_ = &it->second;
    } else {
      expect(w[2] == "=" && w.size() <= 4, "'c' takes: c | c name | c name = | c name = template");
      Colour value;
      if (w.size() == 4) {
        auto it = colours_.find(w[3]);
        if (it == colours_.end()) fail("template colour '" + w[3] + "' is not defined");
        value = it->second;
      }
      Colour& c = colours_[w[1]];
      c = value;
      current_colour_ = &c;
    }
  }

  void material_context(const Statement& s) {
    const auto& w = s.words;
    if (w.size() == 1) {
      const long version = scratch_material_.version;
      const int conversions = scratch_material_.conversions;
      scratch_material_ = MaterialState{};
      scratch_material_.version = version + 1;
      scratch_material_.conversions = conversions;
      current_material_ = &scratch_material_;
    } else if (w.size() == 2) {
      auto it = materials_.find(w[1]);
      if (it == materials_.end()) fail("material '" + w[1] + "' is not defined");
      current_material_ = &it->second;
    } else {
      expect(w[2] == "=" && w.size() <= 4, "'m' takes: m | m name | m name = | m name = template");
      MaterialState value;
      if (w.size() == 4) {
        auto it = materials_.find(w[3]);
        if (it == materials_.end()) fail("template material '" + w[3] + "' is not defined");
        value = it->second;
      }
      MaterialState& m = materials_[w[1]];
      // Keep the version counter and the conversion count running: faces made with the old
      // definition keep their Scene material, faces made with the new one get a new one.
      const long version = m.version;
      const int conversions = m.conversions;
      m = value;
      m.name = w[1];
      m.version = version + 1;
      m.scene_index = -1;
      m.scene_version = -1;
      m.conversions = conversions;
      current_material_ = &m;
    }
  }

  void set_colour(const cie::Xyz& xyz) {
    if (xyz.x >= 0 && xyz.z >= 0 && xyz.y > 0) {
      current_colour_->xy = cie::chromaticity(xyz);
      current_colour_->undefined_at.clear();
    } else {
      current_colour_->undefined_at = file_->path + ":" + std::to_string(where_->line);
    }
  }

  // The current colour, which must have a chromaticity, for `what`.
  const Colour& usable(const Colour& c, const std::string& what) {
    if (!c.undefined_at.empty())
      fail(what + ": the current colour (the spectrum at " + c.undefined_at +
           ") has no positive luminance, hence no chromaticity");
    return c;
  }

  // ---- materials --------------------------------------------------------------------------

  // Linear RGB with luminance Y and the colour's chromaticity. Colours outside the RGB gamut
  // (or, for reflectances, above 1 in a channel) are desaturated towards the grey of the same
  // luminance until they fit: Y, which is what MGF specifies numerically, is kept exactly.
  // A chromaticity with y = 0 (hospital/blokken2.mgf has (0.4, 0)) has no luminance at all; it
  // is taken as the limit y -> 0, which is the most saturated colour of its hue that fits.
  Rgb to_rgb(const Colour& c, double y, double upper, bool& clipped) {
    clipped = false;
    if (y == 0.0) return Rgb(0.0);
    if (std::abs(c.xy.x - 1.0 / 3.0) <= kNeutralTolerance &&
        std::abs(c.xy.y - 1.0 / 3.0) <= kNeutralTolerance)
      return Rgb(y);
    // rgb = grey + s * direction, where the direction has zero luminance.
    Rgb direction;
    double s = 1.0;
    if (c.xy.y > 0) {
      direction = cie::xyz_to_rgb(cie::xyY_to_xyz(c.xy, y)) - Rgb(y);
    } else {
      direction = cie::xyz_to_rgb(cie::Xyz(c.xy.x, 0.0, 1.0 - c.xy.x));
      s = std::numeric_limits<double>::infinity();
      clipped = true;
    }
    for (int k = 0; k < 3; ++k) {
      if (direction[k] < 0.0) s = std::min(s, y / -direction[k]);
      if (direction[k] > 0.0 && y + s * direction[k] > upper)
        s = std::min(s, (upper - y) / direction[k]);
    }
    if (s < 1.0) clipped = true;
    Rgb rgb = Rgb(y) + s * direction;
    for (int k = 0; k < 3; ++k) rgb[k] = std::clamp(rgb[k], 0.0, upper);  // rounding only
    return rgb;
  }

  int material_index() {
    MaterialState& m = *current_material_;
    if (m.scene_index >= 0 && m.scene_version == m.version) return m.scene_index;
    Material out;
    out.name = m.name.empty() ? std::string("(unnamed)") : m.name;
    if (m.conversions > 0) out.name += " #" + std::to_string(m.conversions + 1);
    bool clipped_rho = false, clipped_e = false;
    out.reflectance = to_rgb(m.rd_colour, m.rd, 1.0, clipped_rho);
    out.emission = to_rgb(m.ed_colour, m.ed, std::numeric_limits<double>::infinity(), clipped_e);
    if (clipped_rho || clipped_e) {
      ++stats_.out_of_gamut;
      warn("material '" + out.name + "': colour outside the RGB gamut, desaturated (luminance " +
           "kept)");
    }
    scene_.materials.push_back(std::move(out));
    m.scene_index = int(scene_.materials.size() - 1);
    m.scene_version = m.version;
    ++m.conversions;
    return m.scene_index;
  }

  // ---- geometry ---------------------------------------------------------------------------

  VertexState& vertex(const std::string& name) {
    auto it = vertices_.find(name);
    if (it == vertices_.end()) fail("vertex '" + name + "' is not defined");
    return it->second;
  }

  // Transforms a polygon from the current context to world space and adds it to the scene.
  void emit(std::vector<Vec3> polygon) {
    const XfContext& xf = transforms_.back();
    for (Vec3& p : polygon) p = Vec3(xf.m * glm::dvec4(p, 1.0));
    if (xf.flips) std::reverse(polygon.begin(), polygon.end());
    const int material = material_index();
    if (double(scene_.polygons.size()) + 1 > limits().polygons)
      check_limit("polygons", double(scene_.polygons.size()) + 1,
                  location() + "the scene after includes and array instances");
    scene_.polygons.push_back(
        Polygon{std::move(polygon), material, file_->path + ":" + std::to_string(where_->line)});
  }

  // A tessellated primitive (scene/tessellate.h), counted and added.
  void emit_curved(tessellate::Polygons polygons) {
    for (std::vector<Vec3>& polygon : polygons) {
      ++stats_.tessellated_polygons;
      emit(std::move(polygon));
    }
  }

  void cone(const Vec3& p1, double r1, const Vec3& p2, double r2) {
    if (!(glm::length(p2 - p1) > 0)) fail("end points coincide (use 'ring' for a flat disc)");
    emit_curved(tessellate::cone(p1, r1, p2, r2, segments_));
  }

  void sphere(const Vec3& centre, double radius) {
    if (radius == 0) fail("'sph': the radius must not be zero");
    ++stats_.spheres;
    emit_curved(tessellate::sphere(centre, radius, segments_));
  }

  Vec3 unit_normal_of(const VertexState& c, const std::string& what) {
    if (!(glm::length(c.n) > 0))
      fail("'" + what + "': the centre vertex needs a normal ('n'), which gives its orientation");
    return c.n;
  }

  void ring(const VertexState& centre, double rmin, double rmax) {
    const Vec3 w = unit_normal_of(centre, "ring");
    if (!(rmin >= 0 && rmax > rmin)) fail("'ring': need 0 <= rmin < rmax");
    ++stats_.rings;
    emit_curved(tessellate::ring(centre.p, w, rmin, rmax, segments_));
  }

  void torus(const VertexState& centre, double rmin, double rmax) {
    const Vec3 w = unit_normal_of(centre, "torus");
    const bool inward = rmax < 0;
    if (inward ? !(rmin <= 0 && rmax < rmin) : !(rmin >= 0 && rmax > rmin))
      fail("'torus': need 0 <= rmin < rmax (or both negative, |rmin| < |rmax|, for inward)");
    ++stats_.tori;
    emit_curved(tessellate::torus(centre.p, w, rmin, rmax, segments_));
  }

  void prism(const std::vector<Vec3>& base, double length) {
    if (length == 0) fail("'prism': the length must not be zero");
    if (!(glm::length(geometry::unit_normal(base)) > 0))
      fail("'prism': the base polygon has no area");
    ++stats_.prisms;
    emit_curved(tessellate::prism(base, length));
  }

  // ---- messages ---------------------------------------------------------------------------

  double number(size_t k) { return parse_number(where_->words[k], "'" + where_->words[0] + "'"); }

  double parse_number(const std::string& word, const std::string& what) {
    auto v = text::parse_double(word);
    if (!v || !std::isfinite(*v)) fail(what + ": '" + quoted(word) + "' is not a finite number");
    return *v;
  }

  void expect(bool ok, const std::string& message) {
    if (!ok) fail(message);
  }

  std::string location() const { return file_->path + ":" + std::to_string(where_->line) + ": "; }

  std::string include_chain() const {
    std::string out;
    for (auto it = includes_.rbegin(); it != includes_.rend(); ++it)
      out += " (included from " + *it + ")";
    return out;
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(location() + message + include_chain());
  }

  // Each distinct warning once (an included file or an array repeats its lines).
  bool warn(const std::string& message) {
    std::string text = location() + message;
    if (!warned_.insert(text).second) return false;
    stats_.warnings.push_back(std::move(text));
    return true;
  }

  struct Frame {
    const ParsedFile* file;
    size_t transform_depth;
    size_t object_depth;
  };

  const MgfOptions& options_;
  MgfStats& stats_;
  int segments_ = 16;
  Scene scene_;
  std::map<std::string, std::unique_ptr<ParsedFile>> files_;
  std::vector<Frame> frames_;
  std::vector<std::string> includes_;  // "file:line" of each active include
  fs::path root_;                      // includes must lie inside it (canonical)
  long include_count_ = 0;
  double statements_ = 0;  // executed so far
  double max_statements_ = 0;
  std::set<std::string> warned_;
  const ParsedFile* file_ = nullptr;
  const Statement* where_ = nullptr;
  std::vector<XfContext> transforms_;
  std::vector<int> transform_lines_;
  std::vector<std::pair<std::string, int>> objects_;
  std::unordered_map<std::string, VertexState> vertices_;
  std::unordered_map<std::string, Colour> colours_;
  std::unordered_map<std::string, MaterialState> materials_;
  VertexState scratch_vertex_;
  Colour scratch_colour_;
  MaterialState scratch_material_;
  VertexState* current_vertex_;
  Colour* current_colour_;
  MaterialState* current_material_;
};

}  // namespace

Scene read_mgf(const std::string& path, const MgfOptions& options, MgfStats* stats) {
  MgfStats local;
  MgfStats& out = stats ? *stats : local;
  out = MgfStats{};
  Reader reader(options, out);
  Scene scene = reader.read(path);
  if (options.print_warnings && !out.warnings.empty()) {
    const size_t shown = 5;
    for (size_t i = 0; i < out.warnings.size() && i < shown; ++i) log::warning(out.warnings[i]);
    if (out.warnings.size() > shown)
      log::warning(std::to_string(out.warnings.size() - shown) + " more MGF warnings like these");
  }
  return scene;
}

}  // namespace radlab
