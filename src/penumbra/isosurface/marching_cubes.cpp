#include "penumbra/isosurface/marching_cubes.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <string_view>

#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

// Corners and edges in the classic numbering (Lorensen & Cline; Bourke's tables): corners 0-3 go
// round the face z = 0 from the origin, 4-7 the same at z = 1.
constexpr std::array<std::array<int, 3>, 8> kCorner = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}};

// Each edge by its lower and upper corner and its axis: a vertex is always interpolated from the lower
// voxel up, so the cells sharing an edge compute the same bits.
struct Edge {
  int low, high, axis;
};
constexpr std::array<Edge, 12> kEdges = {{{0, 1, 0}, {1, 2, 1}, {3, 2, 0}, {0, 3, 1}, {4, 5, 0}, {5, 6, 1},
                                          {7, 6, 0}, {4, 7, 1}, {0, 4, 2}, {1, 5, 2}, {2, 6, 2}, {3, 7, 2}}};

// The triangles of each case, three hex digits (edge numbers) a triangle. Case bit n: corner n below
// the isovalue (outside). The 256 cases of the classic table, built from the cube itself: each face
// contributes the segments between its crossed edges — on a face whose below and above corners
// alternate, the segments cut off the below corners (the choice of the classic case 3, index 5), made
// alike in every case so that two cells sharing a face always agree and the surface has no cracks.
// Each segment runs with the below corners on its right seen from outside the cube, so the two cells
// of a face run it in opposite directions; the segments close into loops and each loop is a fan:
// triangles wind counter-clockwise seen from outside (from lower values), consistently across cells.
constexpr std::string_view kTriangles[256] = {
    /*   0 */ "", "083", "019", "183198", "12a", "08312a",
    /*   6 */ "0a902a", "2832982a9", "23b", "0b208b", "01923b", "1b218b198",
    /*  12 */ "1ba13b", "0a10ba08b", "0a90ba03b", "8a98ba", "478", "073047",
    /*  18 */ "019478", "173147194", "12a478", "07304712a", "0a902a478", "2732472942a9",
    /*  24 */ "23b478", "0b207b047", "01923b478", "1b217b147194", "1ba13b478", "0a10ba07b047",
    /*  30 */ "0a90ba03b478", "4a94ba47b", "495", "083495", "054015", "183148154",
    /*  36 */ "12a495", "08312a495", "0540a502a", "2832482542a5", "23b495", "0b208b495",
    /*  42 */ "05401523b", "1b218b148154", "1ba13b495", "0a10ba08b495", "0540a50ba03b", "4a54ba48b",
    /*  48 */ "589578", "073057095", "078057015", "173157", "12a589578", "07305709512a",
    /*  54 */ "0780570a502a", "2732572a5", "23b589578", "0b207b057095", "07805701523b", "1b217b157",
    /*  60 */ "1ba13b589578", "0a10ba07b057095", "0780570a50ba03b", "5ba57b", "5a6", "0835a6",
    /*  66 */ "0195a6", "1831985a6", "165126", "083165126", "059065026", "283298259265",
    /*  72 */ "23b5a6", "0b208b5a6", "01923b5a6", "1b218b1985a6", "1651b613b", "0510650b608b",
    /*  78 */ "0590650b603b", "5b658b598", "4785a6", "0730475a6", "0194785a6", "1731471945a6",
    /*  84 */ "165126478", "073047165126", "059065026478", "273247294259265", "23b4785a6", "0b207b0475a6",
    /*  90 */ "01923b4785a6", "1b217b1471945a6", "1651b613b478", "0510650b607b047", "0590650b603b478", "4594654b647b",
    /*  96 */ "4a649a", "0834a649a", "0640a601a", "1831481641a6", "149164126", "083149164126",
    /* 102 */ "064026", "283248264", "23b4a649a", "0b208b4a649a", "0640a601a23b", "1b218b1481641a6",
    /* 108 */ "1491641b613b", "0910490640b608b", "0640b603b", "4b648b", "69a689678", "0730670a609a",
    /* 114 */ "0780670a601a", "1731671a6", "189178167126", "073067026012091", "078067026", "273267",
    /* 120 */ "23b69a689678", "0b207b0670a609a", "0780670a601a23b", "1b217b1671a6", "1891781671b613b", "09167b",
    /* 126 */ "0780670b603b", "67b", "6b7", "0836b7", "0196b7", "1831986b7",
    /* 132 */ "12a6b7", "08312a6b7", "0a902a6b7", "2832982a96b7", "276237", "062076087",
    /* 138 */ "019276237", "162176187198", "16a176137", "0a106a076087", "0a906a076037", "6876986a9",
    /* 144 */ "4b846b", "0b306b046", "0194b846b", "1b316b146194", "12a4b846b", "0b306b04612a",
    /* 150 */ "0a902a4b846b", "2b326b2462942a9", "246284238", "062046", "019246284238", "162146194",
    /* 156 */ "16a146184138", "0a106a046", "0a906a046084038", "4a946a", "4956b7", "0834956b7",
    /* 162 */ "0540156b7", "1831481546b7", "12a4956b7", "08312a4956b7", "0540a502a6b7", "2832482542a56b7",
    /* 168 */ "276237495", "062076087495", "054015276237", "162176187148154", "16a176137495", "0a106a076087495",
    /* 174 */ "0540a506a076037", "4a546a476487", "5895b856b", "0b306b056095", "0b806b056015", "1b316b156",
    /* 180 */ "12a5895b856b", "0b306b05609512a", "0b806b0560a502a", "2b326b2562a5", "256295289238", "062056095",
    /* 186 */ "038023062056015", "162156", "16a156195189138", "0a106a056095", "03856a", "56a",
    /* 192 */ "5b75ab", "0835b75ab", "0195b75ab", "1831985b75ab", "1751b712b", "0831751b712b",
    /* 198 */ "0590750b702b", "2832982592752b7", "25a275237", "0a205a075087", "01925a275237", "1a215a175187198",
    /* 204 */ "175137", "051075087", "059075037", "587598", "4b84ab45a", "0b30ab05a045",
    /* 210 */ "0194b84ab45a", "1b31ab15a145194", "1451841b812b", "0b302b012051045", "0590450840b802b", "2b3459",
    /* 216 */ "25a245284238", "0a205a045", "01925a245284238", "1a215a145194", "145184138", "051045",
    /* 222 */ "059045084038", "459", "4b74ab49a", "0834b74ab49a", "0740b70ab01a", "1831481741b71ab",
    /* 228 */ "1491741b712b", "0831491741b712b", "0740b702b", "2832482742b7", "29a249274237", "0a209a049074087",
    /* 234 */ "0740370230a201a", "1a2487", "149174137", "091049074087", "074037", "487",
    /* 240 */ "8ab89a", "0b30ab09a", "0b80ab01a", "1b31ab", "1891b812b", "0b302b012091",
    /* 246 */ "0b802b", "2b3", "29a289238", "0a209a", "0380230a201a", "1a2",
    /* 252 */ "189138", "091", "038", ""
};

std::size_t triangle_count(int cube_case) { return kTriangles[cube_case].size() / 3; }

int edge_of(char hex) { return hex <= '9' ? hex - '0' : hex - 'a' + 10; }

// The cells of one slab of bricks (brick z-index `slab`) that hold the surface, for voxels of type T:
// calls visit(cell, values, cube_case) in brick (y, x), then cell (z, y, x) order.
template <class T, class Visit>
void for_each_surface_cell(const GridTree& tree, float isovalue, int slab, Visit&& visit) {
  const Volume& volume = tree.volume();
  const T* data = volume.data_as<T>();
  std::array<std::size_t, 8> offset;
  for (std::size_t n = 0; n < 8; ++n)
    offset[n] = volume.index(kCorner[n][0], kCorner[n][1], kCorner[n][2]) - volume.index(0, 0, 0);
  const auto& bricks = tree.level_dims(0);
  std::array<float, 8> v;
  for (int bj = 0; bj < bricks[1]; ++bj)
    for (int bi = 0; bi < bricks[0]; ++bi) {
      if (!tree.may_contain(0, bi, bj, slab, isovalue)) continue;
      std::array<int, 3> lo, hi;
      tree.node_cells(0, bi, bj, slab, lo, hi);
      for (int k = lo[2]; k < hi[2]; ++k)
        for (int j = lo[1]; j < hi[1]; ++j)
          for (int i = lo[0]; i < hi[0]; ++i) {
            const T* base = data + volume.index(i, j, k);
            int cube_case = 0;
            for (std::size_t n = 0; n < 8; ++n) {
              v[n] = static_cast<float>(base[offset[n]]);
              if (v[n] < isovalue) cube_case |= 1 << n;
            }
            if (cube_case != 0 && cube_case != 255) visit(std::array<int, 3>{i, j, k}, v, cube_case);
          }
    }
}

// The normalized gradient at an edge point: the central differences at its two voxels (clamped at the
// border, as Volume::gradient) interpolated along the edge — Volume::gradient at that point.
template <class T>
class EdgeNormals {
public:
  explicit EdgeNormals(const Volume& volume) : volume_(volume), data_(volume.data_as<T>()) {}

  Vec3 operator()(const std::array<int, 3>& low, int axis, float t) const {
    std::array<int, 3> high = low;
    ++high[static_cast<std::size_t>(axis)];
    return normalize(voxel_gradient(low) * (1 - t) + voxel_gradient(high) * t);
  }

private:
  Vec3 voxel_gradient(const std::array<int, 3>& p) const {
    const auto& d = volume_.dims();
    const Vec3& s = volume_.spacing();
    Vec3 g;
    for (std::size_t a = 0; a < 3; ++a) {
      std::array<int, 3> up = p, down = p;
      up[a] = std::min(p[a] + 1, d[a] - 1);
      down[a] = std::max(p[a] - 1, 0);
      const float diff = static_cast<float>(data_[volume_.index(up[0], up[1], up[2])]) -
                         static_cast<float>(data_[volume_.index(down[0], down[1], down[2])]);
      g[static_cast<int>(a)] = 0.5f * diff / s[static_cast<int>(a)];
    }
    return g;
  }

  const Volume& volume_;
  const T* data_;
};

template <class T>
TriangleMesh marching_cubes_typed(const GridTree& tree, float isovalue) {
  const int slabs = tree.level_dims(0)[2];
  // Count first, so that the mesh is allocated once and each slab fills its own range.
  std::vector<std::size_t> first(static_cast<std::size_t>(slabs) + 1, 0);
  parallel_for(static_cast<std::size_t>(slabs), [&](std::size_t s0, std::size_t s1) {
    for (std::size_t s = s0; s < s1; ++s)
      for_each_surface_cell<T>(tree, isovalue, static_cast<int>(s),
                               [&](const std::array<int, 3>&, const std::array<float, 8>&, int c) { first[s + 1] += triangle_count(c); });
  });
  for (std::size_t s = 0; s < static_cast<std::size_t>(slabs); ++s) first[s + 1] += first[s];
  TriangleMesh mesh;
  mesh.vertices.resize(3 * first.back());
  mesh.normals.resize(3 * first.back());
  const Volume& volume = tree.volume();
  const EdgeNormals<T> edge_normal(volume);
  parallel_for(static_cast<std::size_t>(slabs), [&](std::size_t s0, std::size_t s1) {
    for (std::size_t s = s0; s < s1; ++s) {
      std::size_t out = 3 * first[s];
      for_each_surface_cell<T>(tree, isovalue, static_cast<int>(s), [&](const std::array<int, 3>& cell,
                                                                        const std::array<float, 8>& v, int c) {
        std::array<Vec3, 12> position, normal;
        unsigned done = 0;
        for (char hex : kTriangles[c]) {
          const int e = edge_of(hex);
          if (!(done & (1u << e))) {
            done |= 1u << e;
            const Edge& edge = kEdges[static_cast<std::size_t>(e)];
            const float va = v[static_cast<std::size_t>(edge.low)], vb = v[static_cast<std::size_t>(edge.high)];
            const float t = (isovalue - va) / (vb - va);
            std::array<int, 3> low;
            for (std::size_t a = 0; a < 3; ++a) low[a] = cell[a] + kCorner[static_cast<std::size_t>(edge.low)][a];
            Vec3 p;
            for (int a = 0; a < 3; ++a) {
              const float along = static_cast<float>(low[static_cast<std::size_t>(a)]) + (a == edge.axis ? t : 0.0f);
              p[a] = volume.origin()[a] + along * volume.spacing()[a];
            }
            position[static_cast<std::size_t>(e)] = p;
            normal[static_cast<std::size_t>(e)] = edge_normal(low, edge.axis, t);
          }
          mesh.vertices[out] = position[static_cast<std::size_t>(e)];
          mesh.normals[out++] = normal[static_cast<std::size_t>(e)];
        }
      });
    }
  });
  return mesh;
}

}  // namespace

TriangleMesh marching_cubes(const GridTree& tree, float isovalue) {
  switch (tree.volume().type()) {
    case ScalarType::UInt8: return marching_cubes_typed<std::uint8_t>(tree, isovalue);
    case ScalarType::Int16: return marching_cubes_typed<std::int16_t>(tree, isovalue);
    case ScalarType::UInt16: return marching_cubes_typed<std::uint16_t>(tree, isovalue);
    case ScalarType::Float32: return marching_cubes_typed<float>(tree, isovalue);
  }
  return {};
}

}  // namespace penumbra
