// Where everything is in "ct-body" (ct_body_anatomy.h): an adult female body 1.70 m tall, lying in a
// 500 x 500 x 1734 mm box, x to her left, y anterior. Sizes are rounded textbook values; what matters
// for the isosurface is the topology: nested layers (skin, fat, muscle; the skull's tables and diploë;
// cortex around marrow), hundreds of separate bones and blobs, holes (orbits, foramen magnum, the
// obturator rings) and thin plates (scapulae, iliac wings).
#include "penumbra/data/ct_body_anatomy.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/core/rng.h"
#include "penumbra/data/ct_body.h"

namespace penumbra::ct_anatomy {

namespace {

using namespace ct_tissue;

constexpr double kPi = 3.14159265358979323846;

const std::vector<Knot>& torso_knots() {
  static const std::vector<Knot> knots{{800, 0, -15, 90, 75},   {930, 0, -5, 160, 100},  {1000, 0, -5, 150, 98},
                                       {1060, 0, 0, 125, 90},   {1150, 0, 0, 133, 97},   {1250, 0, 0, 142, 103},
                                       {1350, 0, -3, 155, 100}, {1410, 0, -10, 160, 88}, {1432, 0, -12, 135, 78},
                                       {1448, 0, -15, 80, 62}};
  return knots;
}

// Linear interpolation between knots, clamped to the first and last.
Knot interpolate(const std::vector<Knot>& k, double h) {
  if (h <= k.front().h) return {h, k.front().cx, k.front().cy, k.front().a, k.front().b};
  if (h >= k.back().h) return {h, k.back().cx, k.back().cy, k.back().a, k.back().b};
  const auto hi = std::upper_bound(k.begin(), k.end(), h, [](double v, const Knot& n) { return v < n.h; });
  const Knot& p = *(hi - 1);
  const Knot& q = *hi;
  const double t = (h - p.h) / (q.h - p.h);
  return {h, p.cx + t * (q.cx - p.cx), p.cy + t * (q.cy - p.cy), p.a + t * (q.a - p.a), p.b + t * (q.b - p.b)};
}

// The back's skin (smallest y) at height h: the torso's, or the neck's above the shoulders.
double back_y(double h) {
  if (h >= 1440) return -73;
  const Knot t = torso_at(h);
  return t.cy - t.b;
}

// The painting list under construction, with the seeded random numbers.
class Body {
public:
  explicit Body(std::uint64_t seed) : seed_(seed) {}

  Item& ellipsoid(Point c, Point axes, float value, double shell = 0) {
    Item it;
    it.centre = c;
    it.axes = axes;
    it.value = value;
    it.shell = shell;
    items.push_back(std::move(it));
    return items.back();
  }
  Item& profile(std::vector<Knot> knots, float value, double shell = 0) {
    Item it;
    it.knots = std::move(knots);
    it.value = value;
    it.shell = shell;
    items.push_back(std::move(it));
    return items.back();
  }
  // A straight rod of elliptic section (a, b) from p up to q, cut flat at both ends.
  Item& rod(Point p, Point q, double a, double b, float value) {
    return profile({{p.h, p.x, p.y, a, b}, {q.h, q.x, q.y, a, b}}, value);
  }
  // Spheres of radius r every r/2 along a polyline: a tube in any direction (the union's surface dips
  // by 3% of r between spheres).
  void tube(const std::vector<Point>& path, double r, float value) {
    for (std::size_t s = 0; s + 1 < path.size(); ++s) {
      const Point& p = path[s];
      const Point& q = path[s + 1];
      const double length = std::sqrt((q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) + (q.h - p.h) * (q.h - p.h));
      const int n = std::max(1, static_cast<int>(std::ceil(length / (0.5 * r))));
      for (int i = (s == 0 ? 0 : 1); i <= n; ++i) {
        const double t = static_cast<double>(i) / n;
        ellipsoid({p.x + t * (q.x - p.x), p.y + t * (q.y - p.y), p.h + t * (q.h - p.h)}, {r, r, r}, value);
      }
    }
  }
  // Compact bone around marrow: the outer tube in cortical bone, then the inner one in cancellous.
  void bone_tube(const std::vector<Point>& path, double r, double cortex) {
    tube(path, r, kCortical);
    tube(path, r - cortex, kCancellous);
  }
  // A long bone's shaft: a cortical rod around a marrow rod, its ends closed by the cortex.
  void bone_rod(Point p, Point q, double a, double b, double cortex) {
    rod(p, q, a, b, kCortical);
    rod({p.x, p.y, p.h + cortex}, {q.x, q.y, q.h - cortex}, a - cortex, b - cortex, kCancellous);
  }
  // The end of a long bone, a vertebral body, a carpal: cancellous bone in a 2.5 mm cortical shell.
  void bone_end(Point c, Point axes) {
    ellipsoid(c, axes, kCancellous);
    ellipsoid(c, axes, kCortical, 2.5);
  }
  // A uniform number in [0, 1) keyed by (kind, index, coordinate).
  double random(std::uint64_t kind, std::uint64_t index, std::uint64_t c) const {
    return uniform_float(seed_, kind, index, c);
  }
  // A point uniform in the ellipsoid (c, axes), by rejection from the bounding box.
  Point random_in(std::uint64_t kind, std::uint64_t index, Point c, Point axes) const {
    for (std::uint64_t attempt = 0;; ++attempt) {
      const double u = 2 * random(kind, index, 3 * attempt) - 1, v = 2 * random(kind, index, 3 * attempt + 1) - 1,
                   w = 2 * random(kind, index, 3 * attempt + 2) - 1;
      if (u * u + v * v + w * w <= 1 || attempt == 64) return {c.x + u * axes.x, c.y + v * axes.y, c.h + w * axes.h};
    }
  }

  std::vector<Item> items;

private:
  std::uint64_t seed_;
};

// Skin (2 mm), subcutaneous fat and muscle: every body part is painted three times, each pass over all
// parts, so where parts overlap (shoulders, hips, the neck) the layers join instead of cutting each other.
void body_surface(Body& body) {
  struct Part {
    Item shape;
    double fat;  // thickness under the skin; parts without muscle are fat throughout
    bool muscle;
  };
  std::vector<Part> parts;
  const auto add = [&](Item shape, double fat, bool muscle = true) { parts.push_back({std::move(shape), fat, muscle}); };
  const auto ellipsoid = [](Point c, Point axes) {
    Item it;
    it.centre = c;
    it.axes = axes;
    return it;
  };
  const auto profile = [](std::vector<Knot> knots) {
    Item it;
    it.knots = std::move(knots);
    return it;
  };
  add(profile(torso_knots()), 16);
  add(profile({{1420, 0, -15, 55, 58}, {1500, 0, -10, 52, 58}}), 8);
  add(ellipsoid({0, 3, 1590}, {80, 102, 112}), 3);  // head
  add(ellipsoid({0, 22, 1515}, {64, 72, 50}), 4);   // jaw and cheeks
  add(ellipsoid({0, 104, 1558}, {11, 14, 22}), 2);  // nose
  for (const double s : {-1.0, 1.0}) {
    add(ellipsoid({s * 81, -5, 1590}, {7, 16, 28}), 0, false);    // ear: skin and cartilage-thin fat
    add(ellipsoid({s * 72, 85, 1225}, {62, 50, 60}), 0, false);   // breast
    add(ellipsoid({s * 158, -10, 1400}, {44, 48, 40}), 8);        // shoulder
    add(profile({{845, s * 200, 5, 22, 26}, {950, s * 198, 0, 28, 31}, {1100, s * 195, -10, 32, 35},
                 {1250, s * 190, -15, 38, 41}, {1380, s * 182, -10, 43, 46}, {1410, s * 165, -10, 44, 47}}),
        8);
    add(ellipsoid({s * 200, 10, 765}, {14, 42, 85}), 3);  // hand
    add(profile({{40, s * 75, 5, 30, 32}, {80, s * 75, 5, 30, 33}, {200, s * 75, 5, 38, 42}, {380, s * 76, 0, 55, 58},
                 {480, s * 76, 5, 52, 55}, {600, s * 78, 5, 60, 62}, {800, s * 82, 0, 75, 80}, {925, s * 85, -5, 85, 95}}),
        14);
    add(ellipsoid({s * 76, 55, 42}, {48, 118, 40}), 5);  // foot
  }
  const auto layer = [&](const Item& shape, float value, double inset) {
    body.items.push_back(shape);
    body.items.back().value = value;
    body.items.back().inset = inset;
  };
  for (const Part& p : parts) layer(p.shape, kSkin, 0);
  for (const Part& p : parts) layer(p.shape, kFat, 2);
  for (const Part& p : parts)
    if (p.muscle) layer(p.shape, kMuscle, 2 + p.fat);
  for (const double s : {-1.0, 1.0}) body.ellipsoid({s * 72, 92, 1225}, {32, 26, 34}, kSoft);  // glandular tissue
}

// Lungs with hundreds of small vessels, the airways, the heart.
void thorax_organs(Body& body) {
  for (const double s : {-1.0, 1.0}) body.ellipsoid({s * 64, -4, 1240}, {48, 70, 145}, kLung);
  for (std::uint64_t i = 0; i < 380; ++i) {
    const double s = i % 2 ? 1.0 : -1.0;
    const Point c = body.random_in(1, i, {s * 64, -4, 1240}, {44, 64, 133});
    const double r = 1.2 + 2.3 * body.random(2, i, 0);
    body.ellipsoid(c, {r, r, r}, kSoft);
  }
  body.rod({0, 8, 1310}, {0, 8, 1485}, 11, 11, kCartilage);  // trachea
  body.rod({0, 8, 1305}, {0, 8, 1480}, 8, 8, kAir);
  for (const double s : {-1.0, 1.0}) {
    const std::vector<Point> bronchus{{0, 8, 1315}, {s * 30, 4, 1290}, {s * 55, -2, 1255}};
    body.tube(bronchus, 6.5, kCartilage);
    body.tube(bronchus, 4.5, kAir);
  }
  body.ellipsoid({18, 28, 1175}, {55, 45, 60}, kSoft);  // heart
}

// The abdomen: bowel loops and gas in visceral fat, the solid organs, bladder and uterus.
void abdomen(Body& body) {
  const Point gut{0, 12, 985}, gut_axes{100, 62, 100};
  body.ellipsoid(gut, gut_axes, kVisceral);
  const Point inner{0.85 * gut_axes.x, 0.85 * gut_axes.y, 0.85 * gut_axes.h};
  for (std::uint64_t i = 0; i < 90; ++i)
    body.ellipsoid(body.random_in(3, i, gut, inner),
                   {10 + 12 * body.random(4, i, 0), 10 + 12 * body.random(4, i, 1), 12 + 14 * body.random(4, i, 2)}, kSoft);
  for (std::uint64_t i = 0; i < 70; ++i)
    body.ellipsoid(body.random_in(5, i, gut, inner),
                   {3 + 10 * body.random(6, i, 0), 3 + 10 * body.random(6, i, 1), 3 + 10 * body.random(6, i, 2)}, kAir);
  body.ellipsoid({-45, 12, 1090}, {62, 58, 65}, kOrgan);  // liver
  body.ellipsoid({75, -30, 1090}, {28, 38, 45}, kOrgan);  // spleen
  body.ellipsoid({45, 30, 1110}, {40, 32, 40}, kSoft);    // stomach, with a gas bubble on top
  body.ellipsoid({45, 40, 1138}, {24, 16, 9}, kAir);
  for (const double s : {-1.0, 1.0}) {
    body.ellipsoid({s * 62, -48, 1020}, {26, 20, 52}, kOrgan);  // kidney and its pelvis
    body.ellipsoid({s * 55, -42, 1020}, {10, 8, 28}, kFluid);
  }
  body.ellipsoid({0, 50, 900}, {42, 32, 32}, kFluid);  // bladder
  body.ellipsoid({0, 20, 945}, {30, 22, 35}, kOrgan);  // uterus
}

// The aorta, iliac and femoral arteries (blood, no contrast); their polylines, for the calcifications.
std::vector<std::vector<Point>> arteries(Body& body) {
  std::vector<std::vector<Point>> paths{
      {{12, 40, 1200}, {8, 30, 1265}, {4, 5, 1292}, {12, -22, 1282}, {30, -36, 1250}, {32, -30, 1180}, {14, 5, 1100},
       {8, 22, 1000}}};
  for (const double s : {-1.0, 1.0})
    paths.push_back({{8, 22, 1000}, {s * 40, 25, 950}, {s * 70, 30, 890}, {s * 76, 38, 840}, {s * 72, 35, 520}});
  for (std::size_t p = 0; p < paths.size(); ++p) body.tube(paths[p], p == 0 ? 12 : 6, kSoft);
  return paths;
}

// The skull: outer table, diploë and inner table as nested ellipsoids cut at the skull base, which is a
// plate with the foramen magnum; orbits, sinuses and the nasal cavity make holes and air pockets; the
// mandible and 28 separate teeth below.
void head(Body& body) {
  const Point skull{0, 0, 1598}, axes{72, 92, 100};
  const std::array<std::pair<double, float>, 5> layers{
      {{0, kCortical}, {2, kCancellous}, {5, kCortical}, {7, kFluid}, {9, kSoft}}};
  for (const auto& [inset, value] : layers) {
    Item& layer = body.ellipsoid(skull, axes, value);
    layer.inset = inset;
    layer.hmin = 1538;
  }
  body.ellipsoid({0, -5, 1540}, {60, 80, 5}, kCortical);     // skull base
  body.ellipsoid({0, -30, 1540}, {14, 17, 8}, kSoft);        // foramen magnum
  body.ellipsoid({0, 83, 1630}, {14, 2.5, 9}, kAir);         // frontal sinus
  body.ellipsoid({0, 75, 1555}, {8, 28, 18}, kAir);          // nasal cavity
  for (const double s : {-1.0, 1.0}) {
    body.ellipsoid({s * 33, 75, 1590}, {18, 18, 18}, kFat);  // orbit
    body.ellipsoid({s * 33, 80, 1590}, {12, 12, 12}, kFluid);   // eye
    body.ellipsoid({s * 33, 90, 1590}, {4, 2, 4}, kCartilage);  // lens
    body.ellipsoid({s * 28, 55, 1552}, {15, 18, 16}, kAir);     // maxillary sinus
    body.ellipsoid({s * 9, 0, 1612}, {6, 24, 12}, kFluid);      // ventricle
  }
  body.bone_tube({{-48, -10, 1545}, {-48, 2, 1500}, {-38, 38, 1490}, {-20, 60, 1489}, {0, 66, 1489}, {20, 60, 1489},
                  {38, 38, 1490}, {48, 2, 1500}, {48, -10, 1545}},
                 6, 2.5);  // mandible
  for (int row = 0; row < 2; ++row)
    for (int t = 0; t < 14; ++t) {
      const double theta = -1.25 + 2.5 * t / 13.0;
      body.ellipsoid({24 * std::sin(theta), 28 + 34 * std::cos(theta), row == 0 ? 1503.0 : 1520.0}, {2.6, 2.6, 6}, kEnamel);
    }
}

// 24 vertebrae (7 cervical, 12 thoracic, 5 lumbar) from 1495 mm down, each a separate bone: a body of
// cancellous bone in a cortical shell, an arch around the spinal cord, spinous and transverse
// processes; discs between them; the sacrum and coccyx below. Returns the thoracic bodies' mid-heights.
std::vector<double> spine(Body& body) {
  struct Level {
    int count;
    double height, disc, rx0, rx1, ry, depth;
  };
  const std::array<Level, 3> levels{{{7, 17, 5, 13, 14, 10, 44}, {12, 24, 5, 15, 21, 14, 64}, {5, 33, 7, 22, 24, 17, 76}}};
  struct Vertebra {
    double bottom, top, rx, ry, y;
  };
  std::vector<Vertebra> vertebrae;
  std::vector<double> thoracic;
  double h = 1495;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const Level& lv = levels[l];
    for (int n = 0; n < lv.count; ++n) {
      const double rx = lv.rx0 + (lv.rx1 - lv.rx0) * n / std::max(1, lv.count - 1);
      const double mid = h - 0.5 * (lv.height - lv.disc);
      vertebrae.push_back({h - lv.height + lv.disc, h, rx, lv.ry, back_y(mid) + lv.depth});
      if (l == 1) thoracic.push_back(mid);
      body.rod({0, vertebrae.back().y, h - lv.height}, {0, vertebrae.back().y, h - lv.height + lv.disc}, rx, lv.ry, kOrgan);
      h -= lv.height;
    }
  }
  std::vector<Knot> cord;
  for (auto v = vertebrae.rbegin(); v != vertebrae.rend(); ++v)
    cord.push_back({0.5 * (v->bottom + v->top), 0, v->y - v->ry - 8, 7.5, 5.5});
  body.profile(cord, kSoft);
  for (const Vertebra& v : vertebrae) {
    const double canal = v.y - v.ry - 8;
    body.rod({0, v.y, v.bottom}, {0, v.y, v.top}, v.rx, v.ry, kCortical);
    body.rod({0, v.y, v.bottom + 1.5}, {0, v.y, v.top - 1.5}, v.rx - 1.5, v.ry - 1.5, kCancellous);
    body.rod({0, canal, v.bottom}, {0, canal, v.top}, 11, 9, kCortical).shell = 3.5;  // arch
    body.rod({0, canal - 18, v.bottom}, {0, canal - 18, v.top - 3}, 4, 10, kCortical);      // spinous
    body.rod({0, canal + 2, v.bottom + 2}, {0, canal + 2, v.top - 2}, v.rx + 14, 4.5, kCortical);  // transverse
  }
  body.bone_end({0, back_y(880) + 40, 878}, {42, 16, 44});  // sacrum
  for (int i = 0; i < 3; ++i) body.ellipsoid({0, back_y(850) + 35, 835 - 9.0 * i}, {7.0 - i, 5, 4}, kCortical);  // coccyx
  return thoracic;
}

// Ribs: thin tubes around the torso, each from beside its thoracic vertebra forward and down (true ribs
// to costal cartilage at the sternum, floating ribs short); sternum, clavicles, scapulae.
void rib_cage(Body& body, const std::vector<double>& thoracic) {
  const double depth = 24;  // rib centres under the skin
  for (std::size_t k = 0; k < thoracic.size(); ++k) {
    const double n = static_cast<double>(k);  // 0 for the first rib
    const double scale = k == 0 ? 0.62 : k == 1 ? 0.82 : k == 2 ? 0.93 : 1.0;
    const double drop = 35 + 5 * n;
    const double end = k < 7 ? 2.5 : k < 10 ? 2.3 - 0.05 * (n - 7) : k == 10 ? 1.7 : 1.35;
    for (const double s : {-1.0, 1.0}) {
      // The rib's ellipse shrinks towards the back, where it starts (phi = 0 at the spine).
      const auto at = [&](double phi) {
        const double h = thoracic[k] - drop * std::pow(phi / kPi, 1.6);
        const Knot t = torso_at(h);
        const double ar = (t.a - depth) * scale, br = (t.b - depth) * scale;
        return Point{s * ar * std::sin(phi), t.cy - (t.b - depth) + br * (1 - std::cos(phi)), h};
      };
      std::vector<Point> rib, cartilage;
      for (double phi = 0.45; phi < end; phi += 0.05) rib.push_back(at(phi));
      rib.push_back(at(end));
      body.bone_tube(rib, 5, 1.8);
      if (k < 7) {
        for (double phi = end; phi < kPi - 0.12; phi += 0.05) cartilage.push_back(at(phi));
        cartilage.push_back(at(kPi - 0.12));
        body.tube(cartilage, 4.5, kCartilage);
      }
    }
  }
  const Knot chest = torso_at(1260);
  body.bone_rod({0, chest.cy + chest.b - 28, 1170}, {0, chest.cy + chest.b - 28, 1345}, 17, 6, 2);  // sternum
  for (const double s : {-1.0, 1.0}) {
    body.bone_tube({{s * 20, 62, 1418}, {s * 60, 56, 1424}, {s * 105, 34, 1430}, {s * 145, 6, 1432}}, 6, 2.5);
    // Scapula: a thin plate curved along the back, clear of the ribs.
    Item& scapula = body.profile({{1245, 0, 0, 132, 93}, {1385, 0, -7, 147, 84}}, kCortical, 3.5);
    scapula.xmin = s > 0 ? 40 : -125;
    scapula.xmax = s > 0 ? 125 : -40;
    scapula.ymax = -40;
  }
}

// The pelvis: iliac wings (a shell of an ellipsoid cut to its lateral, posterior part), the acetabular
// cups, and the pubic and ischial bones, which close the obturator rings.
void pelvis(Body& body) {
  for (const double s : {-1.0, 1.0}) {
    Item& wing = body.ellipsoid({s * 68, -20, 985}, {62, 55, 62}, kCortical, 5);
    (s > 0 ? wing.xmin : wing.xmax) = s * 30;  // the lateral part only
    wing.ymax = -5;  // open to the front
    wing.hmin = 920;
    Item& cup = body.ellipsoid({s * 88, 0, 905}, {29, 29, 29}, kCortical, 4);
    (s > 0 ? cup.xmax : cup.xmin) = s * 95;  // the medial part: a cup around the femoral head
    body.bone_tube({{s * 70, 28, 905}, {s * 45, 55, 885}, {s * 10, 62, 878}}, 8, 3);
    body.bone_tube({{s * 80, -20, 895}, {s * 62, -30, 860}, {s * 45, 0, 855}, {s * 40, 35, 870}, {s * 45, 55, 885}}, 7, 2.5);
  }
}

// Arms, hands (8 carpals, 5 metacarpals, 14 phalanges each), legs and feet.
void limbs(Body& body) {
  for (const double s : {-1.0, 1.0}) {
    body.bone_end({s * 170, -10, 1392}, {22, 22, 22});  // humerus
    body.bone_rod({s * 182, -10, 1120}, {s * 178, -10, 1380}, 11, 11, 4);
    body.bone_end({s * 195, -8, 1108}, {22, 13, 11});
    body.bone_rod({s * 187, -2, 860}, {s * 190, -4, 1092}, 6, 6, 2.5);  // radius
    body.bone_rod({s * 206, -14, 860}, {s * 203, -16, 1092}, 6.5, 6.5, 2.5);  // ulna
    for (int c = 0; c < 8; ++c) body.ellipsoid({s * 200, 10 - 18 + 12.0 * (c % 4), c < 4 ? 843.0 : 830.0}, {5, 5, 5}, kCortical);
    for (int m = 0; m < 5; ++m) body.rod({s * 200, 10 + 10.2 * (m - 2), 772}, {s * 200, 10 + 10.2 * (m - 2), 820}, 3.5, 3.5, kCortical);
    for (int f = 0; f < 4; ++f)
      for (const auto& [lo, hi] : {std::pair{748.0, 766.0}, std::pair{728.0, 744.0}, std::pair{712.0, 724.0}})
        body.rod({s * 200, 10 - 18 + 12.0 * f, lo}, {s * 200, 10 - 18 + 12.0 * f, hi}, 3, 3, kCortical);
    for (const auto& [lo, hi] : {std::pair{790.0, 805.0}, std::pair{770.0, 786.0}})
      body.rod({s * 200, 36, lo}, {s * 200, 36, hi}, 3, 3, kCortical);  // thumb

    body.bone_end({s * 88, 0, 905}, {23, 23, 23});  // femur
    body.bone_tube({{s * 95, 0, 900}, {s * 115, 2, 878}}, 13, 3);
    body.bone_end({s * 125, -5, 888}, {17, 17, 24});
    body.bone_rod({s * 80, 8, 515}, {s * 112, 4, 870}, 14, 14, 4.5);
    body.bone_end({s * 77, 5, 492}, {38, 30, 24});
    body.bone_end({s * 76, 48, 500}, {18, 7, 20});  // patella
    body.bone_end({s * 76, 5, 450}, {36, 27, 14});  // tibia
    body.bone_rod({s * 76, 5, 95}, {s * 76, 5, 445}, 12, 12, 4);
    body.bone_end({s * 76, 5, 88}, {20, 18, 14});
    body.bone_rod({s * 102, -10, 85}, {s * 108, -12, 425}, 6, 6, 2.5);  // fibula
    body.bone_end({s * 76, 12, 58}, {16, 20, 13});   // talus
    body.bone_end({s * 76, -22, 32}, {20, 32, 20});  // calcaneus
    for (int m = 0; m < 5; ++m) {
      body.tube({{s * (76 + 7.0 * (m - 2)), 45, 40}, {s * (76 + 9.0 * (m - 2)), 130, 18}}, 4, kCortical);  // metatarsal
      body.ellipsoid({s * (76 + 9.0 * (m - 2)), 148, 28}, {3, 5, 3}, kCortical);                            // toe
    }
  }
}

// Calcifications: plaques on the artery walls, phleboliths in the pelvis, kidney stones and calcified
// granulomas in the lungs; each a separate speck of bone density.
void calcifications(Body& body, const std::vector<std::vector<Point>>& paths) {
  for (std::uint64_t i = 0; i < 140; ++i) {
    const std::vector<Point>& path = paths[i % paths.size()];
    const std::size_t seg = static_cast<std::size_t>(body.random(7, i, 0) * static_cast<double>(path.size() - 1));
    const double t = body.random(7, i, 1), angle = 2 * kPi * body.random(7, i, 2);
    const double wall = (i % paths.size() == 0 ? 12 : 6) + 0.5, r = 0.8 + 1.6 * body.random(7, i, 3);
    const Point& p = path[seg];
    const Point& q = path[seg + 1];
    body.ellipsoid({p.x + t * (q.x - p.x) + wall * std::cos(angle), p.y + t * (q.y - p.y) + wall * std::sin(angle),
                    p.h + t * (q.h - p.h)},
                   {r, r, r}, static_cast<float>(1600 + 800 * body.random(7, i, 4)));
  }
  const auto specks = [&](std::uint64_t kind, int count, Point c, Point axes, double r0, double r1, double v0, double v1) {
    for (std::uint64_t i = 0; i < static_cast<std::uint64_t>(count); ++i) {
      const double r = r0 + (r1 - r0) * body.random(kind + 1, i, 0);
      body.ellipsoid(body.random_in(kind, i, c, axes), {r, r, r}, static_cast<float>(v0 + (v1 - v0) * body.random(kind + 1, i, 1)));
    }
  };
  specks(10, 30, {0, 15, 900}, {60, 40, 22}, 1.5, 3, 1500, 2000);  // phleboliths
  for (const double s : {-1.0, 1.0}) {
    specks(s > 0 ? 12 : 14, 2, {s * 58, -44, 1020}, {6, 5, 18}, 1.5, 3.5, 2000, 2400);           // kidney stones
    specks(s > 0 ? 16 : 18, 6, {s * 64, -4, 1240}, {40, 60, 125}, 1.5, 3, 1800, 2300);          // granulomas
  }
}

}  // namespace

Knot torso_at(double h) { return interpolate(torso_knots(), h); }

bool section(const Item& it, double h, double inset, Knot& out) {
  if (it.knots.empty()) {
    const double a = it.axes.x - inset, b = it.axes.y - inset, c = it.axes.h - inset;
    if (a <= 0 || b <= 0 || c <= 0) return false;
    const double u = (h - it.centre.h) / c;
    if (u * u >= 1) return false;
    const double shrink = std::sqrt(1 - u * u);
    out = {h, it.centre.x, it.centre.y, a * shrink, b * shrink};
    return true;
  }
  out = interpolate(it.knots, h);
  out.a -= inset;
  out.b -= inset;
  return out.a > 0 && out.b > 0;
}

std::pair<double, double> height_range(const Item& it) {
  const double lo = it.knots.empty() ? it.centre.h - it.axes.h : it.knots.front().h + it.inset;
  const double hi = it.knots.empty() ? it.centre.h + it.axes.h : it.knots.back().h - it.inset;
  return {std::max(lo, it.hmin), std::min(hi, it.hmax)};
}

double cover(const Item& it, double h, double step) {
  // An ellipsoid closes by itself; flat ends (profile caps, clip planes) are anti-aliased over a slice.
  const double lo = std::max(it.knots.empty() ? -kInf : it.knots.front().h + it.inset, it.hmin);
  const double hi = std::min(it.knots.empty() ? kInf : it.knots.back().h - it.inset, it.hmax);
  return std::clamp((h - lo) / step + 0.5, 0.0, 1.0) * std::clamp((hi - h) / step + 0.5, 0.0, 1.0);
}

std::vector<Item> build(std::uint64_t seed) {
  Body body(seed);
  body_surface(body);
  thorax_organs(body);
  abdomen(body);
  const auto paths = arteries(body);
  head(body);
  const std::vector<double> thoracic = spine(body);
  rib_cage(body, thoracic);
  pelvis(body);
  limbs(body);
  calcifications(body, paths);
  return std::move(body.items);
}

}  // namespace penumbra::ct_anatomy
