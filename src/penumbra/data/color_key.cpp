#include "penumbra/data/color_key.h"

#include <algorithm>
#include <unordered_map>

#include "penumbra/data/particles.h"

namespace penumbra {
namespace {

// One colour of a categorical key being counted.
struct Slot {
  std::uint32_t color;
  std::unordered_map<std::uint32_t, std::size_t> names;  // name id → spheres
  std::size_t count;
};

// The slot of `color`, found from the last one used (runs of one colour are the rule).
Slot& slot_of(std::vector<Slot>& slots, std::uint32_t color, std::size_t& last) {
  if (last < slots.size() && slots[last].color == color) return slots[last];
  for (last = 0; last < slots.size(); ++last)
    if (slots[last].color == color) return slots[last];
  slots.push_back(Slot{color, {}, 0});
  return slots.back();
}

void sort_by_count(std::vector<ColorKey::Entry>& entries) {
  std::stable_sort(entries.begin(), entries.end(), [](const auto& x, const auto& y) { return x.count > y.count; });
}

}  // namespace

ColorKey categorical_color_key(std::string by, const std::vector<std::uint32_t>& colors,
                               const std::function<std::uint32_t(std::size_t)>& name_id,
                               const std::function<std::string(std::uint32_t)>& name) {
  std::vector<Slot> slots;
  std::size_t last = 0;
  for (std::size_t k = 0; k < colors.size(); ++k) {
    Slot& s = slot_of(slots, colors[k], last);
    ++s.names[name_id(k)];
    ++s.count;
  }
  ColorKey key;
  key.by = std::move(by);
  for (const Slot& s : slots) {
    std::vector<std::pair<std::size_t, std::string>> names;
    for (const auto& [id, count] : s.names) names.emplace_back(count, name(id));
    std::sort(names.begin(), names.end(), [](const auto& x, const auto& y) { return x.first != y.first ? x.first > y.first : x.second < y.second; });
    std::string label;
    for (std::size_t i = 0; i < names.size() && i < ColorKey::kMaxNamesPerEntry; ++i)
      label += (i ? ", " : "") + (names[i].second.empty() ? std::string("(none)") : names[i].second);
    if (names.size() > ColorKey::kMaxNamesPerEntry) label += ", +" + std::to_string(names.size() - ColorKey::kMaxNamesPerEntry) + " more";
    key.entries.push_back({label, s.color, s.count});
  }
  sort_by_count(key.entries);
  return key;
}

ColorKey scalar_color_key(std::string quantity, float lo, float hi, const TransferFunction& map) {
  ColorKey key;
  key.by = "scalar";
  key.quantity = std::move(quantity);
  key.lo = lo;
  key.hi = hi;
  for (std::size_t i = 0; i < ColorKey::kRampSize; ++i) {
    const float t = static_cast<float>(i) / static_cast<float>(ColorKey::kRampSize - 1);
    key.ramp.push_back(pack_rgba8(map.evaluate(lo + t * (hi - lo)).rgb));
  }
  return key;
}

void recount(ColorKey& key, const std::vector<std::uint32_t>& colors) {
  if (key.entries.empty()) return;
  for (auto& e : key.entries) e.count = 0;
  std::size_t last = 0;
  for (const std::uint32_t c : colors) {
    if (last >= key.entries.size() || key.entries[last].color != c) {
      last = 0;
      while (last < key.entries.size() && key.entries[last].color != c) ++last;
      if (last == key.entries.size()) continue;  // a colour the key does not know (none: picked or copied)
    }
    ++key.entries[last].count;
  }
  std::erase_if(key.entries, [](const auto& e) { return e.count == 0; });
  sort_by_count(key.entries);
}

}  // namespace penumbra
