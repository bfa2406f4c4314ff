// The scene file and its --set overrides: the input is the scene's JSON text, then any number of
// "key=value" overrides, each after a NUL byte. The steps of load_scene are run one by one (read the
// file, apply each override, build the scene) so that, before the build, what would only cost time or
// memory is defused: procedural volumes and sphere sets are made small (a 512x512x1734 ct-body or 100 M
// random spheres is legal input) and file names that reach outside the fuzzer's directory are replaced.
#include <string>
#include <vector>

#include "fuzz_common.h"
#include "penumbra/scene_io/scene_file.h"

namespace {

void defuse(nlohmann::json& j) {
  if (j.is_array()) {
    for (auto& e : j) defuse(e);
    return;
  }
  if (!j.is_object()) return;
  for (auto it = j.begin(); it != j.end(); ++it) {
    nlohmann::json& v = it.value();
    if (it.key() == "file" && v.is_string()) {
      const std::string f = v.get<std::string>();
      if (f.find('/') != std::string::npos || f.find("..") != std::string::npos) v = "missing.nrrd";
    }
    if (it.key() == "procedural" && v.is_object()) {
      for (const char* key : {"size", "count"})
        if (v.contains(key) && v[key].is_number_integer() && v[key].get<std::int64_t>() > 24) v[key] = 24;
      if (v.contains("dims") && v["dims"].is_array()) {
        for (auto& d : v["dims"])
          if (d.is_number_integer() && d.get<std::int64_t>() > 16) d = 16;
      } else if (v.contains("name") && v["name"] == "ct-body") {
        v["dims"] = {16, 16, 16};
      }
    }
    defuse(v);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t nul = input.find('\0');
  const std::string scene_text = input.substr(0, nul);
  std::vector<std::string> overrides;
  for (std::size_t pos = nul; pos != std::string::npos && pos < input.size();) {
    const std::size_t next = input.find('\0', pos + 1);
    overrides.push_back(input.substr(pos + 1, next == std::string::npos ? std::string::npos : next - pos - 1));
    pos = next;
  }
  const std::string path = penumbra::fuzz::write_input("in.json", reinterpret_cast<const std::uint8_t*>(scene_text.data()),
                                                       scene_text.size());
  penumbra::fuzz::expect_error_or_result([&] {
    nlohmann::json j = penumbra::read_json_file(path);
    for (const auto& o : overrides) penumbra::apply_override(j, o);
    defuse(j);
    (void)penumbra::build_scene(j, penumbra::fuzz::work_dir().string());
  });
  return 0;
}
