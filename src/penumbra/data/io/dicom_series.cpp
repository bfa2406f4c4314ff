#include "penumbra/data/io/dicom_series.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "penumbra/core/error.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::dicom {

using io_detail::printable;

std::string series_line(std::size_t index, const Series& s) {
  return std::to_string(index) + ": " + (s.uid.empty() ? "(no SeriesInstanceUID)" : s.uid) +
         (s.number ? " number " + std::to_string(*s.number) : "") + " \"" + printable(s.description, 80) + "\" " +
         (s.modality.empty() ? "?" : printable(s.modality, 16)) + ", " + std::to_string(s.slices.size()) + " slice" +
         (s.slices.size() == 1 ? "" : "s") + " of " + std::to_string(s.slices[0].rows) + "x" + std::to_string(s.slices[0].cols) + " (rows x columns)";
}

// Series in a stable order: by SeriesNumber, then UID (the order of the files does not matter).
std::vector<Series> group_series(std::vector<Slice> slices) {
  std::map<std::string, Series> by_uid;
  for (Slice& s : slices) {
    Series& series = by_uid[s.series_uid];
    if (series.slices.empty()) series.uid = s.series_uid, series.description = s.description, series.modality = s.modality, series.number = s.series_number;
    series.slices.push_back(std::move(s));
  }
  std::vector<Series> out;
  for (auto& [uid, series] : by_uid) out.push_back(std::move(series));
  std::stable_sort(out.begin(), out.end(), [](const Series& a, const Series& b) {
    return a.number.value_or(std::numeric_limits<long>::max()) < b.number.value_or(std::numeric_limits<long>::max());
  });
  return out;
}

std::size_t choose_series(const std::vector<Series>& all, const std::string& wanted, VolumeFileInfo& info) {
  if (wanted.empty()) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < all.size(); ++i)
      if (all[i].slices.size() > all[best].slices.size()) best = i;
    if (all.size() > 1)
      info.notes.push_back("the input holds " + std::to_string(all.size()) + " series; loaded series " + std::to_string(best) +
                           ", the one with the most slices (choose another with 'series': its index or SeriesInstanceUID)");
    return best;
  }
  for (std::size_t i = 0; i < all.size(); ++i)
    if (all[i].uid == wanted) return i;
  if (wanted.find_first_not_of("0123456789") == std::string::npos && wanted.size() < 9 && std::stoul(wanted) < all.size())
    return std::stoul(wanted);
  std::string list;
  for (const std::string& line : info.series) list += "; " + line;
  throw Error("no series '" + printable(wanted, 80) + "' (expected a SeriesInstanceUID or an index from 0 to " + std::to_string(all.size() - 1) +
              "): the input holds" + list.substr(1));
}

void check_consistent(const std::vector<Slice>& slices) {
  const Slice& ref = slices[0];
  auto expect = [&](const Slice& s, bool same, const std::string& what, const std::string& found, const std::string& wanted) {
    if (!same) throw Error(s.name + ": " + what + " is " + found + ", expected " + wanted + " as in " + ref.name + " of the same series");
  };
  auto list = [](const auto& v) {
    std::string out;
    for (const double x : v) out += (out.empty() ? "" : "\\") + dec(x);
    return out;
  };
  auto close = [](const auto& a, const auto& b, double tol) {
    if (a.has_value() != b.has_value()) return false;
    for (std::size_t i = 0; a && i < a->size(); ++i)
      if (std::abs((*a)[i] - (*b)[i]) > tol) return false;
    return true;
  };
  auto opt_list = [&](const auto& v) { return v ? list(*v) : std::string("missing"); };
  for (const Slice& s : slices) {
    expect(s, s.rows == ref.rows, "Rows", std::to_string(s.rows), std::to_string(ref.rows));
    expect(s, s.cols == ref.cols, "Columns", std::to_string(s.cols), std::to_string(ref.cols));
    expect(s, s.bits_allocated == ref.bits_allocated, "BitsAllocated", std::to_string(s.bits_allocated), std::to_string(ref.bits_allocated));
    expect(s, s.bits_stored == ref.bits_stored, "BitsStored", std::to_string(s.bits_stored), std::to_string(ref.bits_stored));
    expect(s, s.is_signed == ref.is_signed, "PixelRepresentation", s.is_signed ? "1" : "0", ref.is_signed ? "1" : "0");
    expect(s, close(s.pixel_spacing, ref.pixel_spacing, 1e-4), "PixelSpacing", opt_list(s.pixel_spacing), opt_list(ref.pixel_spacing));
    expect(s, close(s.orientation, ref.orientation, 1e-4), "ImageOrientationPatient", opt_list(s.orientation), opt_list(ref.orientation));
    if (!s.position && slices.size() > 1) throw Error(s.name + ": no ImagePositionPatient " + tag_str(kPosition) + " (expected to order the slices by it)");
  }
}

using Vec3d = std::array<double, 3>;

double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
std::string vec_str(const Vec3d& v) { return "(" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + ")"; }

// The patient axis (0, 1, 2) and sign of a direction cosine along one, or -1 when it is oblique.
std::pair<int, int> axis_of(const Vec3d& v) {
  for (int a = 0; a < 3; ++a)
    if (std::abs(std::abs(v[a]) - 1) < 1e-3) return {a, v[a] > 0 ? 1 : -1};
  return {-1, 0};
}

std::string axis_str(const std::pair<int, int>& axis) { return std::string(axis.second > 0 ? "+" : "-") + "xyz"[axis.first]; }


Layout arrange(const std::vector<Slice>& input, VolumeFileInfo& info) {
  Layout L;
  const Slice& first = input[0];
  const std::size_t n = input.size();
  std::array<double, 6> iop{1, 0, 0, 0, 1, 0};
  if (first.orientation) iop = *first.orientation;
  else info.notes.push_back("no ImageOrientationPatient: the slice is taken as axial (rows along +x, columns along +y)");
  Vec3d r{iop[0], iop[1], iop[2]}, c{iop[3], iop[4], iop[5]};
  const double lr = std::sqrt(dot(r, r)), lc = std::sqrt(dot(c, c));
  if (std::abs(lr - 1) > 0.01 || std::abs(lc - 1) > 0.01 || std::abs(dot(r, c)) > 0.01)
    throw Error(first.name + ": ImageOrientationPatient " + vec_str(r) + " " + vec_str(c) + " (expected two orthogonal unit vectors)");
  for (double& x : r) x /= lr;
  for (double& x : c) x /= lc;
  const Vec3d normal = cross(r, c);

  // Sort along the normal; check the steps.
  std::vector<std::pair<double, const Slice*>> at;
  for (const Slice& s : input) at.push_back({s.position ? dot(*s.position, normal) : 0.0, &s});
  std::stable_sort(at.begin(), at.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double step = 0;
  if (n > 1) {
    std::vector<double> diffs;
    for (std::size_t k = 1; k < n; ++k) diffs.push_back(at[k].first - at[k - 1].first);
    std::vector<double> sorted = diffs;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>((n - 2) / 2), sorted.end());
    step = sorted[(n - 2) / 2];
    const double tol = std::max(0.01 * step, 0.01);
    for (std::size_t k = 1; k < n; ++k) {
      const Slice& a = *at[k - 1].second;
      const Slice& b = *at[k].second;
      const std::string pair = a.name + " (at " + num(at[k - 1].first) + " mm along the slice normal) and " + b.name + " (at " +
                               num(at[k].first) + " mm)";
      if (diffs[k - 1] < tol) throw Error("two slices at the same position: " + pair);
      const double missing = diffs[k - 1] / step - 1;  // slices missing between the two
      const std::string apart = num(diffs[k - 1]) + " mm apart, expected the step " + num(step) + " mm";
      if (std::abs(missing - std::round(missing)) * step < tol && missing > 0.5)
        throw Error("missing slice" + std::string(missing > 1.5 ? "s" : "") + " between " + pair + ": they are " + apart);
      if (std::abs(diffs[k - 1] - step) > tol) throw Error("slices not evenly spaced: " + pair + " are " + apart);
    }
    // Positions that also move within the slice plane (a tilted gantry) make a sheared grid.
    double shear = 0;
    for (const auto& [d, s] : at)
      for (int a = 0; a < 3; ++a) shear = std::max(shear, std::abs((*s->position)[a] - (*at[0].second->position)[a] - (d - at[0].first) * normal[a]));
    if (shear > tol)
      info.notes.push_back("slice positions move up to " + num(shear) + " mm within the slice plane (gantry tilt?): the shear is not applied");
    if (first.thickness && std::abs(*first.thickness - step) > tol)
      info.notes.push_back("slice spacing " + num(step) + " mm from ImagePositionPatient differs from SliceThickness " + num(*first.thickness) +
                           " mm: the positions are used");
  } else {
    step = first.thickness.value_or(1);
    info.notes.push_back("a single slice: its spacing along z is " +
                         (first.thickness ? "the SliceThickness, " + num(step) + " mm" : std::string("1 (no SliceThickness)")));
  }
  for (const auto& [d, s] : at) L.slices.push_back(s);

  bool same = true, reversed = true;
  for (std::size_t k = 0; k < n; ++k) same = same && L.slices[k] == &input[k], reversed = reversed && L.slices[k] == &input[n - 1 - k];
  if (n > 1)
    info.notes.push_back(std::string("slices sorted by ImagePositionPatient along the slice normal: ") +
                         (same ? "the file order" : reversed ? "file order reversed" : "not the file order"));

  std::array<double, 2> ps{1, 1};
  if (first.pixel_spacing) ps = *first.pixel_spacing;
  else info.notes.push_back("no PixelSpacing: the spacing within a slice is 1");
  const std::array<int, 3> grid{first.cols, first.rows, static_cast<int>(n)};
  const std::array<double, 3> grid_spacing{ps[1], ps[0], step};  // PixelSpacing is (between rows, between columns)
  const std::array<Vec3d, 3> dirs{r, c, normal};
  const std::array<std::pair<int, int>, 3> axes{axis_of(r), axis_of(c), axis_of(normal)};
  const bool aligned = axes[0].first >= 0 && axes[1].first >= 0 && axes[2].first >= 0;
  Vec3d origin = L.slices[0]->position.value_or(Vec3d{0, 0, 0});
  if (!L.slices[0]->position) info.notes.push_back("no ImagePositionPatient: the origin is 0");
  std::array<int, 3> to{0, 1, 2};     // volume axis of each grid axis
  std::array<bool, 3> flip{};
  if (aligned) {
    static const char* const plane[] = {"sagittal", "coronal", "axial"};
    info.orientation = std::string(plane[axes[2].first]) + " (rows along " + axis_str(axes[0]) + ", columns along " + axis_str(axes[1]) +
                       "), slices sorted by position along " + axis_str(axes[2]) + "; volume axes = patient LPS";
    for (int m = 0; m < 3; ++m) {
      to[m] = axes[m].first;
      flip[m] = axes[m].second < 0;
      if (flip[m])
        for (int a = 0; a < 3; ++a) origin[a] += (grid[m] - 1) * grid_spacing[m] * dirs[m][a];
    }
  } else {
    info.orientation = "oblique (rows along " + vec_str(r) + ", columns along " + vec_str(c) + "), slices sorted along the normal " +
                       vec_str(normal) + "; volume axes = columns, rows, slices";
    info.notes.push_back("oblique slices: the rotation is not applied; the volume is rendered on the slice grid (x along the rows, y down the "
                         "columns, z along the normal), with the first slice's ImagePositionPatient as origin");
  }
  for (int m = 0; m < 3; ++m) {
    L.dims[to[m]] = grid[m];
    L.spacing[to[m]] = static_cast<float>(grid_spacing[m]);
  }
  const std::array<std::int64_t, 3> stride{1, L.dims[0], static_cast<std::int64_t>(L.dims[0]) * L.dims[1]};
  L.origin = {static_cast<float>(origin[0]), static_cast<float>(origin[1]), static_cast<float>(origin[2])};
  std::array<std::vector<std::int64_t>*, 3> offsets{&L.col, &L.row, &L.slice};
  for (int m = 0; m < 3; ++m)
    for (int i = 0; i < grid[m]; ++i) offsets[m]->push_back((flip[m] ? grid[m] - 1 - i : i) * stride[to[m]]);
  return L;
}

}  // namespace penumbra::dicom
