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

  // Sort along the normal; check the steps against their median (duplicates, missing slices), then fit
  // the positions against the slice number: positions rounded in the file (0.625 mm slices written to
  // two decimals: -50.00, -49.38, -48.75 ...) give the true spacing, not their median gap.
  std::vector<std::pair<double, const Slice*>> at;
  for (const Slice& s : input) at.push_back({s.position ? dot(*s.position, normal) : 0.0, &s});
  std::stable_sort(at.begin(), at.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double step = 0;
  Vec3d step_vector{0, 0, 0}, fitted_first = input[0].position.value_or(Vec3d{0, 0, 0});
  if (n > 1) {
    std::vector<double> diffs;
    for (std::size_t k = 1; k < n; ++k) diffs.push_back(at[k].first - at[k - 1].first);
    std::vector<double> sorted = diffs;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>((n - 2) / 2), sorted.end());
    const double median = sorted[(n - 2) / 2];
    const double tol = std::max(0.01 * median, 0.01);
    const auto pair_of = [&](std::size_t k) {
      return at[k - 1].second->name + " (at " + num(at[k - 1].first) + " mm along the slice normal) and " + at[k].second->name + " (at " +
             num(at[k].first) + " mm)";
    };
    for (std::size_t k = 1; k < n; ++k) {
      if (diffs[k - 1] < tol) throw Error("two slices at the same position: " + pair_of(k));
      const double missing = diffs[k - 1] / median - 1;  // slices missing between the two
      if (std::abs(missing - std::round(missing)) * median < tol && missing > 0.5)
        throw Error("missing slice" + std::string(missing > 1.5 ? "s" : "") + " between " + pair_of(k) + ": they are " + num(diffs[k - 1]) +
                    " mm apart, expected the step " + num(median) + " mm");
    }
    // Least squares of each coordinate of the positions against the slice number k.
    const double mean_k = 0.5 * static_cast<double>(n - 1);
    double skk = 0;
    Vec3d mean{0, 0, 0}, skp{0, 0, 0};
    for (const auto& [d, s] : at)
      for (int a = 0; a < 3; ++a) mean[a] += (*s->position)[a] / static_cast<double>(n);
    for (std::size_t k = 0; k < n; ++k) {
      const double dk = static_cast<double>(k) - mean_k;
      skk += dk * dk;
      for (int a = 0; a < 3; ++a) skp[a] += dk * ((*at[k].second->position)[a] - mean[a]);
    }
    for (int a = 0; a < 3; ++a) step_vector[a] = skp[a] / skk, fitted_first[a] = mean[a] - mean_k * step_vector[a];
    step = dot(step_vector, normal);
    for (std::size_t k = 0; k < n; ++k) {
      const double expected = dot(fitted_first, normal) + step * static_cast<double>(k);
      if (std::abs(at[k].first - expected) > tol)
        throw Error("slices not evenly spaced: " + at[k].second->name + " is at " + num(at[k].first) + " mm along the slice normal, " +
                    num(at[k].first - expected) + " mm from the step " + num(step) + " mm fitted through all " + std::to_string(n) +
                    " slices" + (k > 0 ? " (" + pair_of(k) + ")" : ""));
    }
    if (std::abs(step - median) > 1e-6)
      info.notes.push_back("slice spacing " + num(step) + " mm from a least-squares fit through the " + std::to_string(n) +
                           " positions (their median gap is " + num(median) + " mm)");
    // Positions that also move within the slice plane (a tilted gantry) make a sheared grid.
    Vec3d in_plane = step_vector;
    for (int a = 0; a < 3; ++a) in_plane[a] -= step * normal[a];
    const double shear = std::sqrt(dot(in_plane, in_plane)) * static_cast<double>(n - 1);
    if (shear <= tol)
      for (int a = 0; a < 3; ++a) step_vector[a] = step * normal[a];
    else
      info.notes.push_back("slice positions move " + num(shear) + " mm within the slice plane over the series (gantry tilt?): the grid is sheared");
    if (first.thickness && std::abs(*first.thickness - step) > tol)
      info.notes.push_back("slice spacing " + num(step) + " mm from ImagePositionPatient differs from SliceThickness " + num(*first.thickness) +
                           " mm: the positions are used");
  } else {
    step = first.thickness.value_or(1);
    for (int a = 0; a < 3; ++a) step_vector[a] = step * normal[a];
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
  if (!L.slices[0]->position) info.notes.push_back("no ImagePositionPatient: the origin is 0");
  L.dims = {first.cols, first.rows, static_cast<int>(n)};
  // The file's grid: columns step along the row direction by the spacing between columns, rows along the
  // column direction (PixelSpacing is: between rows, between columns), slices by the fitted step.
  for (int a = 0; a < 3; ++a) {
    L.affine.linear[a][0] = r[a] * ps[1];
    L.affine.linear[a][1] = c[a] * ps[0];
    L.affine.linear[a][2] = step_vector[a];
    L.affine.offset[a] = n > 1 ? fitted_first[a] : L.slices[0]->position.value_or(Vec3d{0, 0, 0})[a];
  }
  const std::array<std::pair<int, int>, 3> axes{axis_of(r), axis_of(c), axis_of(normal)};
  if (axes[0].first >= 0 && axes[1].first >= 0 && axes[2].first >= 0) {
    static const char* const plane[] = {"sagittal", "coronal", "axial"};
    info.orientation = std::string(plane[axes[2].first]) + " (rows along " + axis_str(axes[0]) + ", columns along " + axis_str(axes[1]) +
                       "), slices sorted by position along " + axis_str(axes[2]) + "; volume axes = patient LPS";
  } else {
    info.orientation = "oblique (rows along " + vec_str(r) + ", columns along " + vec_str(c) + "), slices sorted along the normal " +
                       vec_str(normal) + "; resampled onto patient LPS axes";
  }
  const std::array<std::int64_t, 3> stride{1, L.dims[0], static_cast<std::int64_t>(L.dims[0]) * L.dims[1]};
  std::array<std::vector<std::int64_t>*, 3> offsets{&L.col, &L.row, &L.slice};
  for (int m = 0; m < 3; ++m)
    for (int i = 0; i < L.dims[m]; ++i) offsets[m]->push_back(i * stride[m]);
  return L;
}

}  // namespace penumbra::dicom
