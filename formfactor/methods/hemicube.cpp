#include "formfactor/methods/hemicube.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>

#include "core/error.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/method_infos.h"
#include "formfactor/visibility/visibility.h"

namespace radlab {

FormFactorMethodInfo hemicube_method_info() {
  return {"hemicube",
          "Cohen-Greenberg hemicube at each element's centre: z-buffered item buffer, one row per "
          "hemicube (aliasing included)",
          {{"resolution", "", "pixels across the top face (even; side faces R x R/2)"},
           {"weights", "",
            "midpoint: classic delta form factors; exact: integrated pixel weights (sum 1)"}},
          configure_from_options<HemicubeFormFactors, HemicubeOptions>(),
          /*rows_at_points=*/true};
}

HemicubeOptions HemicubeOptions::from(ParamBag& bag) {
  HemicubeOptions o;
  o.resolution = int(bag.get_int("resolution", o.resolution, kIntMin, kIntMax));
  const std::string w =
      bag.get_choice("weights", o.weights == HemicubeWeighting::kExact ? "exact" : "midpoint",
                     {"midpoint", "exact"});
  o.weights = w == "exact" ? HemicubeWeighting::kExact : HemicubeWeighting::kMidpoint;
  o.validate();
  return o;
}

void HemicubeOptions::validate() const {
  if (resolution < 2 || resolution > 2048 || resolution % 2 != 0)
    throw UsageError("hemicube: resolution must be an even number in [2,2048], got " +
                     std::to_string(resolution));
}

std::string HemicubeOptions::canonical() const {
  return "resolution=" + std::to_string(resolution) +
         ",weights=" + (weights == HemicubeWeighting::kExact ? "exact" : "midpoint");
}

namespace {

std::vector<double> compute_weights(int R, HemicubeWeighting weighting) {
  const HemicubeLayout layout{R};
  std::vector<double> w(layout.pixels());
  const double h = 2.0 / R, dA = h * h;
  std::vector<Vec3> scratch;
  const Vec3 eye(0.0), up(0.0, 0.0, 1.0);
  // Top face: pixel (a, b) covers s in [a h - 1, (a+1) h - 1], t likewise, at height 1.
  for (int b = 0; b < R; ++b)
    for (int a = 0; a < R; ++a) {
      const double s0 = a * h - 1.0, s1 = (a + 1) * h - 1.0;
      const double t0 = b * h - 1.0, t1 = (b + 1) * h - 1.0;
      double weight;
      if (weighting == HemicubeWeighting::kMidpoint) {
        const double s = 0.5 * (s0 + s1), t = 0.5 * (t0 + t1), q = s * s + t * t + 1.0;
        weight = dA / (std::numbers::pi * q * q);
      } else {
        const Vec3 corners[4] = {{s0, t0, 1.0}, {s1, t0, 1.0}, {s1, t1, 1.0}, {s0, t1, 1.0}};
        weight = point_to_polygon_form_factor(eye, up, corners, Vec3(0, 0, -1), scratch);
      }
      w[size_t(b) * size_t(R) + size_t(a)] = weight;
    }
  // One side face (the one at x = 1; the others are the same by symmetry): pixel (a, b) covers
  // s in [a h - 1, (a+1) h - 1] across and height t in [b h, (b+1) h].
  const size_t side = size_t(R) * size_t(R / 2);
  std::vector<double> one_side(side);
  for (int b = 0; b < R / 2; ++b)
    for (int a = 0; a < R; ++a) {
      const double s0 = a * h - 1.0, s1 = (a + 1) * h - 1.0;
      const double t0 = b * h, t1 = (b + 1) * h;
      double weight;
      if (weighting == HemicubeWeighting::kMidpoint) {
        const double s = 0.5 * (s0 + s1), t = 0.5 * (t0 + t1), q = s * s + t * t + 1.0;
        weight = t * dA / (std::numbers::pi * q * q);
      } else {
        const Vec3 corners[4] = {{1.0, s0, t0}, {1.0, s1, t0}, {1.0, s1, t1}, {1.0, s0, t1}};
        weight = point_to_polygon_form_factor(eye, up, corners, Vec3(-1, 0, 0), scratch);
      }
      one_side[size_t(b) * size_t(R) + size_t(a)] = weight;
    }
  for (int face = 1; face <= 4; ++face)
    std::copy(one_side.begin(), one_side.end(),
              w.begin() + std::ptrdiff_t(layout.face_offset(face)));
  return w;
}

// Face axes in the local frame (0 = u, 1 = v, 2 = n): depth axis and its sign, s axis, t axis.
struct FaceAxes {
  int d, s, t;
  double d_sign;
};
constexpr std::array<FaceAxes, 5> kFaces = {{
    {2, 0, 1, 1.0},   // top: depth z, s = x/z, t = y/z
    {0, 1, 2, 1.0},   // +u: depth x, s = y/x, t = z/x
    {0, 1, 2, -1.0},  // -u
    {1, 0, 2, 1.0},   // +v: depth y, s = x/y, t = z/y
    {1, 0, 2, -1.0},  // -v
}};

constexpr uint8_t kBelow = 5;  // vertex below i's horizon
constexpr uint8_t kNear = 6;   // vertex at the eye (cannot be projected)
constexpr int kMaxClip = 24;   // an element's corners (+1 after the near plane)

// Cracks. Elements of different polygons that meet along a line without sharing corners
// (T-junctions between polygons meshed differently) have edges that agree only up to rounding
// (~1e-9 of the scene after snapping), and a pixel centre lying on such a line — common in
// symmetric scenes — can fall between them and see through. So every front-facing element also
// records the pixels whose centre lies within kSlack pixels outside it ("candidates"). The
// nearest candidate of a pixel takes it when
//   - the pixel holds nothing and candidates of two or more elements claim it (a crack between
//     visible elements, with nothing behind);
//   - the pixel holds a back face at about the candidate's depth (within kCandidateMargin,
//     relative, in 1/depth): a silhouette whose front and back faces were meshed differently,
//     where a back face can never legitimately show;
//   - two or more elements claim it and what it holds is farther by kCandidateMargin.
// A pixel just outside one element's silhouette (one candidate, over nothing or over a farther
// front face) is left alone, and an element never takes a pixel from a front-facing neighbour
// whose edge it shares (equal depth there), so this adds no bias where pixel centres lie exactly
// on shared edges.
struct Candidate {
  uint32_t pixel;  // index in the buffers of the whole hemicube
  float w;
  int32_t id;
};
constexpr double kSlack = 1e-4;
constexpr double kCandidateMargin = 1e-5;

// Scan-converts a convex polygon given in pixel coordinates (X, Y) onto one face. A pixel is
// covered when its centre (a + 1/2, b + 1/2) lies in the polygon, half-open: rows with
// ymin <= y < ymax, and in a row the centres with xl <= x < xr. Each edge's crossing is computed
// from its two ends in a canonical order, so two polygons sharing an edge (bit-identical ends)
// get bit-identical crossings and a centre on the edge goes to exactly one of them: no holes, no
// pixel counted twice, no bias in symmetric scenes. Pixels whose centre lies within kSlack
// outside the polygon become candidates (see Candidate). `w = a0 + aX X + aY Y` is 1/depth
// (larger is nearer). Returns the number of depth tests.
// When `drawn` is given, the weights (`face_weights`) of every pixel whose centre the polygon
// covers are added to it, before any depth test: the footprint's sampled form factor.
uint64_t scan_convert(const double* X, const double* Y, int m, int width, int height, double a0,
                      double aX, double aY, int32_t id, float* depth, int32_t* item,
                      uint32_t face_offset, std::vector<Candidate>& candidates,
                      const double* face_weights, double* drawn) {
  double ymin = Y[0], ymax = Y[0];
  for (int k = 1; k < m; ++k) {
    ymin = std::min(ymin, Y[k]);
    ymax = std::max(ymax, Y[k]);
  }
  // Clamp before converting: corners near a face's eye plane project very far out.
  auto first_at_or_after = [](double x, int limit) {  // smallest a with a + 1/2 >= x
    return int(std::ceil(std::clamp(x - 0.5, 0.0, double(limit))));
  };
  auto last_at_or_before = [](double x, int limit) {  // largest a with a + 1/2 <= x, or -1
    return int(std::floor(std::clamp(x - 0.5, -1.0, double(limit - 1))));
  };
  auto candidate = [&](int a, int b) {
    if (id < 0) return;  // back faces never fill a crack
    const double w = a0 + aX * (a + 0.5) + aY * (b + 0.5);
    candidates.push_back({face_offset + uint32_t(b) * uint32_t(width) + uint32_t(a), float(w), id});
  };
  const int b0 = first_at_or_after(ymin, height);
  const int b1 = first_at_or_after(ymax, height);  // exclusive
  // Rows whose centre lies just outside [ymin, ymax): the polygon there is its corners (or its
  // horizontal edge) within kSlack of the row.
  const int be0 = first_at_or_after(ymin - kSlack, height);
  const int be1 = last_at_or_before(ymax + kSlack, height);
  for (int b = be0; b <= be1; ++b) {
    if (b >= b0 && b < b1) continue;
    const double yc = b + 0.5;
    double xl = std::numeric_limits<double>::infinity(), xr = -xl;
    for (int k = 0; k < m; ++k)
      if (std::abs(Y[k] - yc) <= kSlack) {
        xl = std::min(xl, X[k]);
        xr = std::max(xr, X[k]);
      }
    if (!(xl <= xr)) continue;
    const int ae1 = last_at_or_before(xr + kSlack, width);
    for (int a = first_at_or_after(xl - kSlack, width); a <= ae1; ++a) candidate(a, b);
  }
  uint64_t tests = 0;
  for (int b = b0; b < b1; ++b) {
    const double yc = b + 0.5;
    double xl = std::numeric_limits<double>::infinity(), xr = -xl;
    for (int k = 0; k < m; ++k) {
      const int q = k + 1 == m ? 0 : k + 1;
      double xa = X[k], ya = Y[k], xb = X[q], yb = Y[q];
      if (ya > yb) {  // canonical: lower end first (horizontal edges never cross a row)
        std::swap(xa, xb);
        std::swap(ya, yb);
      }
      if (!(ya <= yc && yc < yb)) continue;
      const double x = xa + (yc - ya) / (yb - ya) * (xb - xa);
      xl = std::min(xl, x);
      xr = std::max(xr, x);
    }
    if (!(xl <= xr)) continue;
    const int a0i = first_at_or_after(xl, width);
    const int a1i = first_at_or_after(xr, width);  // exclusive
    for (int a = first_at_or_after(xl - kSlack, width); a < a0i; ++a) candidate(a, b);
    const int ae1 = last_at_or_before(xr + kSlack, width);
    for (int a = std::max(a1i, 0); a <= ae1; ++a) candidate(a, b);
    if (a0i >= a1i) continue;
    if (drawn)
      for (int a = a0i; a < a1i; ++a) *drawn += face_weights[size_t(b) * size_t(width) + size_t(a)];
    float* drow = depth + size_t(b) * size_t(width);
    int32_t* irow = item + size_t(b) * size_t(width);
    const double wrow = a0 + aY * yc;
    for (int a = a0i; a < a1i; ++a) {
      const float w = float(wrow + aX * (a + 0.5));
      if (w > drow[a]) {
        drow[a] = w;
        irow[a] = id;
      }
    }
    tests += uint64_t(a1i - a0i);
  }
  return tests;
}

}  // namespace

std::vector<double> hemicube_weights(int resolution, HemicubeWeighting weighting) {
  // Once per (R, weighting) in the process: methods built repeatedly (tests, sweeps) share them.
  static std::mutex mutex;
  static std::map<std::pair<int, int>, std::shared_ptr<const std::vector<double>>> cache;
  std::shared_ptr<const std::vector<double>> found;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find({resolution, int(weighting)});
    if (it != cache.end()) found = it->second;
  }
  if (!found) {
    found = std::make_shared<const std::vector<double>>(compute_weights(resolution, weighting));
    std::lock_guard<std::mutex> lock(mutex);
    cache.emplace(std::make_pair(resolution, int(weighting)), found);
  }
  return *found;
}

struct HemicubeFormFactors::Buffers {
  std::vector<float> depth;  // 1/depth of the nearest surface so far; 0 = nothing
  std::vector<int32_t> item;
  std::vector<Vec3> local;     // mesh vertices in i's frame
  std::vector<uint8_t> face;   // per vertex: the face its direction falls on, kBelow or kNear
  std::vector<double> px, py;  // per vertex: pixel coordinates on that face
  std::vector<Candidate> candidates;
  std::vector<double> drawn;  // per emitter slot: the footprint's sampled form factor

  void prepare(const HemicubeLayout& layout, size_t vertex_count, size_t emitters) {
    drawn.assign(emitters, 0.0);
    depth.assign(layout.pixels(), 0.0f);
    item.assign(layout.pixels(), kNothing);
    local.resize(vertex_count);
    face.resize(vertex_count);
    px.resize(vertex_count);
    py.resize(vertex_count);
    candidates.clear();
  }
};

HemicubeFormFactors::HemicubeFormFactors(const Scene& scene, const Mesh& mesh,
                                         HemicubeOptions options)
    : mesh_(mesh), options_((options.validate(), options)) {
  // The clipper holds kMaxClip - 6 corners (each near-plane and face cut adds some): an element
  // with more would be skipped, i.e. invisible to every hemicube. Refused, not dropped.
  for (size_t e = 0; e < mesh.size(); ++e)
    if (const size_t m = mesh.element_vertices(e).size(); m > size_t(kMaxClip - 6))
      throw InputError(scene.polygons[mesh.polygon[e]].origin + ": element " + std::to_string(e) +
                       " has " + std::to_string(m) + " corners; the hemicube rasterises at most " +
                       std::to_string(kMaxClip - 6) +
                       " (use --subdiv 2 or more, which splits n-gons into triangles, or another "
                       "form-factor method)");
  weights_ = hemicube_weights(options_.resolution, options_.weights);
  epsilon_ = plane_epsilon(mesh);
  near_ = 100.0 * epsilon_;
  // A power of two near 2^-30 of the scene's size (epsilon_ is 1e-9 of it).
  grid_ = epsilon_ > 0 ? std::ldexp(1.0, std::ilogb(epsilon_)) : 1.0;
  frame_u_.resize(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    const auto corners = mesh.element_vertices(e);
    const Vec3& n = mesh.normal[e];
    Vec3 u = mesh.vertices[corners[1]] - mesh.vertices[corners[0]];
    u -= glm::dot(u, n) * n;
    double length = glm::length(u);
    if (!(length > 0)) {  // degenerate first edge: any tangent
      u = std::abs(n.x) < 0.9 ? glm::cross(n, Vec3(1, 0, 0)) : glm::cross(n, Vec3(0, 1, 0));
      length = glm::length(u);
    }
    frame_u_[e] = u / length;
  }
  emitter_luminance_.assign(mesh.size(), 0.0);
  emitter_slot_.assign(mesh.size(), -1);
  for (size_t e = 0; e < mesh.size(); ++e) {  // elements of a polygon are consecutive
    const Rgb& emission =
        scene.materials[size_t(scene.polygons[mesh.polygon[e]].material)].emission;
    const double luminance = (emission.x + emission.y + emission.z) / 3.0;
    if (!(luminance > 0)) continue;
    emitter_luminance_[e] = luminance;
    emitter_slot_[e] = int32_t(emitters_.size());
    emitters_.push_back(uint32_t(e));
  }
  row_emitter_error_.assign(mesh.size(), std::numeric_limits<float>::quiet_NaN());
  row_emitter_exact_ = row_emitter_error_;
}

namespace {

// Sum of the classic (midpoint) delta form factors of a hemicube of resolution R: the largest a
// raw hemicube row can sum to (each pixel holds one element).
double midpoint_weight_sum(int R) {
  double sum = 0.0;
  const double d = 2.0 / R;
  for (int a = 0; a < R; ++a)
    for (int b = 0; b < R; ++b) {  // top face z = 1, x, y in [-1, 1]
      const double x = -1 + (a + 0.5) * d, y = -1 + (b + 0.5) * d;
      const double r2 = x * x + y * y + 1.0;
      sum += d * d / (M_PI * r2 * r2);
    }
  for (int a = 0; a < R; ++a)
    for (int b = 0; b < R / 2; ++b) {  // one side face x = 1, y in [-1, 1], z in [0, 1]; four
      const double y = -1 + (a + 0.5) * d, z = (b + 0.5) * d;
      const double r2 = y * y + z * z + 1.0;
      sum += 4.0 * z * d * d / (M_PI * r2 * r2);
    }
  return sum;
}

}  // namespace

double HemicubeFormFactors::stated_row_sum_error(std::string* basis) const {
  const int R = options_.resolution;
  const bool midpoint = options_.weights == HemicubeWeighting::kMidpoint;
  const double excess = midpoint ? std::max(0.0, midpoint_weight_sum(R) - 1.0) : 0.0;
  const double error = excess + 1e-6 + kFloatStorageRowError;
  if (basis) {
    char buffer[300];
    std::snprintf(buffer, sizeof buffer,
                  "hemicube: a raw row is at most the sum of its pixel weights (%s: 1 + %.3g) + "
                  "rounding 1e-6",
                  midpoint ? "midpoint" : "exact", excess);
    *basis = buffer;
  }
  return error;
}

std::vector<std::string> HemicubeFormFactors::left_out() const {
  return {"visibility rays: none (a z-buffered item buffer per row)",
          "elements wholly at or below the receiver's horizon, or edge-on to its centre: not "
          "rasterised (pairs_culled)"};
}

uint64_t HemicubeFormFactors::rasterise(size_t i, Buffers& buf, RowCost& cost) const {
  return rasterise_at(mesh_.centroid[i], mesh_.normal[i], frame_u_[i], int64_t(i), buf, cost);
}

void HemicubeFormFactors::project_vertices(const Vec3& c, const Vec3& n, const Vec3& u,
                                           const Vec3& v, Buffers& buf) const {
  const double eps = epsilon_;
  const double near = near_;
  const double half = 0.5 * options_.resolution;
  const double grid = grid_, inverse_grid = 1.0 / grid_;
  auto snap = [&](double x) { return std::nearbyint(x * inverse_grid) * grid; };

  // Every vertex once: local coordinates, the face its direction falls on, pixel coordinates.
  for (size_t k = 0; k < mesh_.vertices.size(); ++k) {
    const Vec3 d = mesh_.vertices[k] - c;
    // Snapped to a grid of 2^-30 of the scene's size: corners that different polygons compute
    // separately (equal up to rounding) become bit-identical, so everything derived from them
    // (projections, near-plane cuts, edge crossings) agrees too, and an edge two elements share
    // stays watertight even where a pixel centre lies exactly on it (common in symmetric
    // scenes). The displacement, ~1e-9 of the scene, is far below the hemicube's aliasing.
    const Vec3 p(snap(glm::dot(d, u)), snap(glm::dot(d, v)), snap(glm::dot(d, n)));
    buf.local[k] = p;
    const double ax = std::abs(p.x), ay = std::abs(p.y);
    if (p.z < -eps) {
      buf.face[k] = kBelow;
    } else if (p.z >= ax && p.z >= ay) {
      if (p.z <= near) {
        buf.face[k] = kNear;
        continue;
      }
      buf.face[k] = 0;
      buf.px[k] = (p.x / p.z + 1.0) * half;
      buf.py[k] = (p.y / p.z + 1.0) * half;
    } else {
      const bool along_u = ax >= ay;
      const double depth = along_u ? ax : ay;
      if (depth <= near) {
        buf.face[k] = kNear;
        continue;
      }
      buf.face[k] = uint8_t(along_u ? (p.x > 0 ? 1 : 2) : (p.y > 0 ? 3 : 4));
      buf.px[k] = ((along_u ? p.y : p.x) / depth + 1.0) * half;
      buf.py[k] = p.z / depth * half;
    }
  }
}

int HemicubeFormFactors::project_onto_face(const Vec3* poly, int m, int f, double near, double half,
                                           Vec3* clipped, double* X, double* Y) {
  const FaceAxes& fa = kFaces[size_t(f)];
  // The face's frustum: d - s >= 0, d + s >= 0, d - t >= 0, (top: d + t, sides: t) >= 0.
  // All corners outside one of these planes: the element cannot reach the face.
  bool rejected = false;
  for (int plane = 0; plane < 4 && !rejected; ++plane) {
    bool all_out = true;
    for (int k = 0; k < m && all_out; ++k) {
      const Vec3& p = poly[k];
      const double d = fa.d_sign * p[fa.d], sp = p[fa.s], tp = p[fa.t];
      const double value = plane == 0   ? d - sp
                           : plane == 1 ? d + sp
                           : plane == 2 ? d - tp
                                        : (f == 0 ? d + tp : tp);
      all_out = value < 0;
    }
    rejected = all_out;
  }
  if (rejected) return 0;
  double value[kMaxClip];
  bool any_near = false;
  for (int k = 0; k < m; ++k) {
    value[k] = fa.d_sign * poly[k][fa.d] - near;
    any_near = any_near || value[k] < 0;
  }
  const Vec3* work = poly;
  int count = m;
  if (any_near) {
    count = 0;
    for (int k = 0; k < m; ++k) {
      const int q = k + 1 == m ? 0 : k + 1;
      if (value[k] >= 0) clipped[count++] = poly[k];
      if ((value[k] >= 0) != (value[q] >= 0)) {
        // Canonical order of the two ends, so a shared edge is cut at the same point.
        const bool swap =
            poly[q].x < poly[k].x ||
            (poly[q].x == poly[k].x &&
             (poly[q].y < poly[k].y || (poly[q].y == poly[k].y && poly[q].z < poly[k].z)));
        const Vec3& P = swap ? poly[q] : poly[k];
        const Vec3& Q = swap ? poly[k] : poly[q];
        const double vP = swap ? value[q] : value[k], vQ = swap ? value[k] : value[q];
        clipped[count++] = P + (vP / (vP - vQ)) * (Q - P);
      }
    }
    work = clipped;
  }
  if (count < 3) return 0;
  // The same arithmetic as project_vertices, so shared corners agree.
  for (int k = 0; k < count; ++k) {
    const Vec3& p = work[k];
    const double d = fa.d_sign * p[fa.d];
    X[k] = (p[fa.s] / d + 1.0) * half;
    Y[k] = f == 0 ? (p[fa.t] / d + 1.0) * half : p[fa.t] / d * half;
  }
  return count;
}

void HemicubeFormFactors::resolve_cracks(Buffers& buf) {
  // Cracks: pixels claimed by candidates of two or more elements (see Candidate).
  auto& cands = buf.candidates;
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    return a.pixel != b.pixel ? a.pixel < b.pixel : a.id < b.id;
  });
  for (size_t k = 0; k < cands.size();) {
    size_t end = k;
    const Candidate* nearest = &cands[k];
    int elements = 0;
    for (; end < cands.size() && cands[end].pixel == cands[k].pixel; ++end) {
      if (end == k || cands[end].id != cands[end - 1].id) ++elements;
      if (cands[end].w > nearest->w) nearest = &cands[end];
    }
    float& d = buf.depth[nearest->pixel];
    int32_t& it = buf.item[nearest->pixel];
    const double w = nearest->w;
    const bool take = d == 0.0f        ? elements >= 2
                      : it == kNothing ? w >= double(d) * (1.0 - kCandidateMargin)
                                       : elements >= 2 && w > double(d) * (1.0 + kCandidateMargin);
    if (take) {
      d = nearest->w;
      it = nearest->id;
    }
    k = end;
  }
}

uint64_t HemicubeFormFactors::rasterise_at(const Vec3& c, const Vec3& n, const Vec3& u,
                                           int64_t skip, Buffers& buf, RowCost& cost) const {
  const int R = options_.resolution;
  const HemicubeLayout layout{R};
  buf.prepare(layout, mesh_.vertices.size(), emitters_.size());
  const Vec3 v = glm::cross(n, u);
  const double eps = epsilon_;
  const double near = near_;
  const double half = 0.5 * R;
  project_vertices(c, n, u, v, buf);

  uint64_t tests = 0;
  double X[kMaxClip], Y[kMaxClip];
  Vec3 poly[kMaxClip], clipped[kMaxClip];
  for (size_t j = 0; j < mesh_.size(); ++j) {
    if (int64_t(j) == skip) continue;
    const auto corners = mesh_.element_vertices(j);
    const int m = int(corners.size());
    bool above = false;
    for (uint32_t k : corners) above = above || buf.local[k].z > eps;
    const Vec3& nj = mesh_.normal[j];
    const double h = glm::dot(nj, mesh_.centroid[j] - c);  // plane of j: dot(N, p) = h locally
    if (!above || std::abs(h) <= eps || m > kMaxClip - 6) {
      ++cost.pairs_culled;
      continue;
    }
    const int32_t id = h < 0 ? int32_t(j) : kNothing;  // back faces occlude, add nothing
    const Vec3 N(glm::dot(nj, u), glm::dot(nj, v), glm::dot(nj, n));
    // 1/depth on face f at pixel (X, Y): (N.e_d + s N.e_s + t N.e_t) / h with s = X/half - 1
    // and t = Y/half - 1 (top) or Y/half (sides).
    // A back face is pushed back by a relative 1e-6 (a few float ulps of 1/depth): where it
    // meets a front face along a silhouette edge their depths tie, and a back face must never win
    // such a tie (it would show as a hole in a closed scene).
    const double scale = id == kNothing ? (1.0 - 1e-6) / h : 1.0 / h;
    double* drawn =
        emitter_slot_[j] >= 0 && id != kNothing ? &buf.drawn[size_t(emitter_slot_[j])] : nullptr;
    // Scan-converts the polygon (X, Y)[0, count) on face f with j's 1/depth plane there.
    auto rasterise_on = [&](int f, int count) {
      const FaceAxes& fa = kFaces[size_t(f)];
      const double Nd = fa.d_sign * N[fa.d], Ns = N[fa.s], Nt = N[fa.t];
      const double a0 = (Nd - Ns - (f == 0 ? Nt : 0.0)) * scale;
      const double aX = Ns / half * scale, aY = Nt / half * scale;
      const size_t offset = layout.face_offset(f);
      tests += scan_convert(X, Y, count, R, layout.face_height(f), a0, aX, aY, id,
                            buf.depth.data() + offset, buf.item.data() + offset, uint32_t(offset),
                            buf.candidates, weights_.data() + offset, drawn);
    };

    const uint8_t f0 = buf.face[corners[0]];
    bool one_face = f0 < kBelow;
    for (int k = 1; k < m && one_face; ++k) one_face = buf.face[corners[size_t(k)]] == f0;
    if (one_face) {
      for (int k = 0; k < m; ++k) {
        X[k] = buf.px[corners[size_t(k)]];
        Y[k] = buf.py[corners[size_t(k)]];
      }
      rasterise_on(f0, m);
      continue;
    }

    // Straddles faces or the horizon: every face it may reach. A face needs no clipping to its
    // square (the scan conversion keeps to the face's pixels), only to its near plane
    // d >= near so that every corner can be projected; one plane per face, so a shared edge is
    // cut at the same point for both elements and stays watertight.
    for (int k = 0; k < m; ++k) poly[k] = buf.local[corners[size_t(k)]];
    for (int f = 0; f < 5; ++f) {
      const int count = project_onto_face(poly, m, f, near, half, clipped, X, Y);
      if (count == 0) continue;
      rasterise_on(f, count);
    }
  }
  resolve_cracks(buf);
  return tests;
}

void HemicubeFormFactors::row(size_t i, std::span<double> out, RowCost& cost) const {
  thread_local Buffers buffers;
  cost.kernel_evaluations += rasterise(i, buffers, cost);
  accumulate(buffers, out);
  record_emitter_sampling(i, buffers);
}

void HemicubeFormFactors::record_emitter_sampling(size_t i, const Buffers& buffers) const {
  // Per emitting polygon, the signed sum over its elements: pixels on an edge two of its elements
  // share go to exactly one of them, so only the polygon's outline is sampled.
  thread_local std::vector<Vec3> corners, scratch;
  double error = 0.0, exact = 0.0, polygon_error = 0.0;
  for (size_t k = 0; k < emitters_.size(); ++k) {
    const size_t j = emitters_[k];
    if (j != i) {
      mesh_.corners(j, corners);
      const double point = point_to_polygon_form_factor(mesh_.centroid[i], mesh_.normal[i], corners,
                                                        mesh_.normal[j], scratch);
      const double L = emitter_luminance_[j];
      exact += L * point;
      polygon_error += L * (buffers.drawn[k] - point);
    }
    const bool polygon_ends =
        k + 1 == emitters_.size() || mesh_.polygon[emitters_[k + 1]] != mesh_.polygon[j];
    if (polygon_ends) {
      error += std::abs(polygon_error);
      polygon_error = 0.0;
    }
  }
  const float up = float(error);
  row_emitter_error_[i] =
      double(up) >= error ? up : std::nextafter(up, std::numeric_limits<float>::infinity());
  row_emitter_exact_[i] = float(exact);
}

std::optional<FormFactorMethod::EmitterSampling> HemicubeFormFactors::row_emitter_sampling(
    size_t i) const {
  return EmitterSampling{double(row_emitter_error_[i]), double(row_emitter_exact_[i])};
}

void HemicubeFormFactors::save_side_files(const std::string& matrix_file) const {
  std::vector<float> data = row_emitter_error_;
  data.insert(data.end(), row_emitter_exact_.begin(), row_emitter_exact_.end());
  // Best effort: without it the matrix is rebuilt. Bound to the matrix file's header and key,
  // with a checksum (formfactor/matrix/matrix_cache.h).
  write_matrix_side_file(matrix_file, ".emitters", data.data(), data.size() * sizeof(float));
}

bool HemicubeFormFactors::load_side_files(const std::string& matrix_file, size_t n) const {
  const auto bytes = read_matrix_side_file(matrix_file, ".emitters", 2 * n * sizeof(float));
  if (!bytes || n != row_emitter_error_.size()) return false;
  std::vector<float> data(2 * n);
  std::memcpy(data.data(), bytes->data(), bytes->size());
  for (float v : data)
    if (!(v >= 0.0f && v < std::numeric_limits<float>::infinity()))
      return false;  // not computed, negative or infinite: not a complete build's
  row_emitter_error_.assign(data.begin(), data.begin() + std::ptrdiff_t(n));
  row_emitter_exact_.assign(data.begin() + std::ptrdiff_t(n), data.end());
  return true;
}

void HemicubeFormFactors::row_at(const Vec3& eye, const Vec3& normal, const Vec3& u,
                                 std::span<double> out, RowCost& cost) const {
  thread_local Buffers buffers;
  cost.kernel_evaluations += rasterise_at(eye, normal, u, -1, buffers, cost);
  accumulate(buffers, out);
}

void HemicubeFormFactors::accumulate(const Buffers& buffers, std::span<double> out) const {
  std::fill(out.begin(), out.end(), 0.0);
  const size_t pixels = weights_.size();
  const int32_t* item = buffers.item.data();
  const double* w = weights_.data();
  for (size_t p = 0; p < pixels; ++p)
    if (item[p] >= 0) out[size_t(item[p])] += w[p];
}

void HemicubeFormFactors::item_buffer(size_t i, std::vector<int32_t>& items) const {
  Buffers buffers;
  RowCost cost;
  rasterise(i, buffers, cost);
  items = buffers.item;
}

}  // namespace radlab
