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
// alternate, the segments cut off the below corners, the choice of the classic case 3 (index 5), made
// alike in every case so that two cells sharing a face always agree and the surface has no cracks —
// the segments close into loops, each loop is a fan wound counter-clockwise seen from outside.
constexpr std::string_view kTriangles[256] = {
    /*   0 */ "", "083", "019", "198183", "12a", "08312a",
    /*   6 */ "02a0a9", "2a9298283", "23b", "08b0b2", "01923b", "19818b1b2",
    /*  12 */ "13b1ba", "08b0ba0a1", "03b0ba0a9", "8ba8a9", "478", "047073",
    /*  18 */ "019478", "194147173", "12a478", "04707312a", "02a0a9478", "23727424929a",
    /*  24 */ "23b478", "04707b0b2", "01923b478", "19414717b1b2", "13b1ba478", "04707b0ba0a1",
    /*  30 */ "03b0ba0a9478", "47b4ba4a9", "495", "083495", "015054", "154148183",
    /*  36 */ "12a495", "08312a495", "02a0a5054", "2a5254248283", "23b495", "08b0b2495",
    /*  42 */ "01505423b", "15414818b1b2", "13b1ba495", "08b0ba0a1495", "03b0ba0a5054", "48b4ba4a5",
    /*  48 */ "578589", "095057073", "015057078", "157173", "12a578589", "09505707312a",
    /*  54 */ "02a0a5057078", "2a5257273", "23b578589", "09505707b0b2", "01505707823b", "15717b1b2",
    /*  60 */ "13b1ba578589", "09505707b0ba0a1", "03b0ba0a5057078", "57b5ba", "5a6", "0835a6",
    /*  66 */ "0195a6", "1981835a6", "126165", "083126165", "026065059", "265259298283",
    /*  72 */ "23b5a6", "08b0b25a6", "01923b5a6", "19818b1b25a6", "13b1b6165", "01505606b0b8",
    /*  78 */ "03b0b6065059", "59858b5b6", "4785a6", "0470735a6", "0194785a6", "1941471735a6",
    /*  84 */ "126165478", "047073126165", "026065059478", "265259294247273", "23b4785a6", "04707b0b25a6",
    /*  90 */ "01923b4785a6", "19414717b1b25a6", "13b1b6165478", "04707b0b6065051", "03b0b6065059478", "47b4b6465459",
    /*  96 */ "49a4a6", "08349a4a6", "01a0a6064", "1a6164148183", "126164149", "083126164149",
    /* 102 */ "026064", "264248283", "23b49a4a6", "08b0b249a4a6", "01a0a606423b", "1a616414818b1b2",
    /* 108 */ "13b1b6164149", "01909404606b0b8", "03b0b6064", "48b4b6", "67868969a", "03707606a0a9",
    /* 114 */ "01a0a6067078", "1a6167173", "126167178189", "037076062021019", "026067078", "267273",
    /* 120 */ "23b67868969a", "09a0a606707b0b2", "01a0a606707823b", "1a616717b1b2", "13b1b6167178189", "09167b",
    /* 126 */ "03b0b6067078", "67b", "6b7", "0836b7", "0196b7", "1981836b7",
    /* 132 */ "12a6b7", "08312a6b7", "02a0a96b7", "2a92982836b7", "237276", "087076062",
    /* 138 */ "019237276", "126167178189", "13717616a", "08707606a0a1", "03707606a0a9", "6a9698687",
    /* 144 */ "46b4b8", "04606b0b3", "01946b4b8", "19414616b1b3", "12a46b4b8", "04606b0b312a",
    /* 150 */ "02a0a946b4b8", "23b2b626424929a", "238284246", "046062", "019238284246", "194146162",
    /* 156 */ "13818414616a", "04606a0a1", "09a0a6064048083", "46a4a9", "4956b7", "0834956b7",
    /* 162 */ "0150546b7", "1541481836b7", "12a4956b7", "08312a4956b7", "02a0a50546b7", "2a52542482836b7",
    /* 168 */ "237276495", "087076062495", "015054237276", "154148187176162", "13717616a495", "08707606a0a1495",
    /* 174 */ "03707606a0a5054", "45a4a6467478", "56b5b8589", "09505606b0b3", "01505606b0b8", "15616b1b3",
    /* 180 */ "12a56b5b8589", "09505606b0b312a", "02a0a505606b0b8", "23b2b626525a", "238289295256", "095056062",
    /* 186 */ "083032026065051", "156162", "13818919515616a", "09505606a0a1", "03856a", "56a",
    /* 192 */ "5ab5b7", "0835ab5b7", "0195ab5b7", "1981835ab5b7", "12b1b7175", "08312b1b7175",
    /* 198 */ "02b0b7075059", "2b7275259298283", "23727525a", "08707505a0a2", "01923727525a", "12a1a5157178189",
    /* 204 */ "137175", "087075051", "037075059", "598587", "45a4ab4b8", "04505a0ab0b3",
    /* 210 */ "01945a4ab4b8", "19414515a1ab1b3", "12b1b8184145", "04505101202b0b3", "02b0b8084045059", "2b3459",
    /* 216 */ "23828424525a", "04505a0a2", "01923828424525a", "12a1a5154149", "138184145", "045051",
    /* 222 */ "038084045059", "459", "49a4ab4b7", "08349a4ab4b7", "01a0ab0b7074", "1ab1b7174148183",
    /* 228 */ "12b1b7174149", "08312b1b7174149", "02b0b7074", "2b7274248283", "23727424929a", "08707404909a0a2",
    /* 234 */ "01a0a2023037074", "1a2487", "137174149", "019094047078", "037074", "487",
    /* 240 */ "89a8ab", "09a0ab0b3", "01a0ab0b8", "1ab1b3", "12b1b8189", "03b0b2021019",
    /* 246 */ "02b0b8", "2b3", "23828929a", "09a0a2", "01a0a2023038", "1a2",
    /* 252 */ "138189", "091", "038", ""
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
