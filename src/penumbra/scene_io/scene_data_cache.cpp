// SceneDataCache (scene_file.h): loaded data kept between readings of an edited scene.
#include "penumbra/scene_io/scene_file.h"

#include "penumbra/data/transfer_function_choice.h"

namespace penumbra {

std::shared_ptr<Volume> SceneDataCache::volume(const std::string& key, const std::function<Volume()>& load) {
  used_.insert("v" + key);
  auto& v = volumes_[key];
  if (!v) v = std::make_shared<Volume>(load());
  return v;
}

std::shared_ptr<const ParticleSet> SceneDataCache::particles(const std::string& key, const std::function<ParticleSet()>& load) {
  used_.insert("p" + key);
  auto& p = particles_[key];
  if (!p) p = std::make_shared<const ParticleSet>(load());
  return p;
}

const SeriesGrid& SceneDataCache::series(const std::string& key, const Volume& step, const std::string& file) {
  used_.insert("s" + key);
  auto it = series_.find(key);
  if (it == series_.end())
    it = series_.emplace(key, SeriesGrid{step.dims(), step.type(), step.spacing(), step.origin(), step.min_value(),
                                         step.max_value(), file}).first;
  return it->second;
}

double& SceneDataCache::frame_time_ps(const std::string& key) {
  used_.insert("f" + key);
  return frame_times_[key];
}

std::shared_ptr<const ParticleFile> SceneDataCache::particle_file(const std::string& path,
                                                                  const std::function<std::shared_ptr<const ParticleFile>()>& read) {
  used_.insert("a" + path);
  auto& f = particle_files_[path];
  if (!f) f = read();
  return f;
}

std::optional<std::size_t>& SceneDataCache::selected_atoms(const std::string& key) {
  used_.insert("n" + key);
  return selected_atoms_[key];
}

std::shared_ptr<const std::vector<std::uint32_t>> SceneDataCache::selected_indices(
    const std::string& key, const std::function<std::vector<std::uint32_t>()>& evaluate) {
  used_.insert("i" + key);
  auto& s = selected_indices_[key];
  if (!s) s = std::make_shared<const std::vector<std::uint32_t>>(evaluate());
  return s;
}

TrajectoryReader& SceneDataCache::trajectory(const std::string& key, const std::function<std::unique_ptr<TrajectoryReader>()>& open) {
  used_.insert("r" + key);
  auto& t = trajectories_[key];
  if (!t) t = open();
  return *t;
}

const nlohmann::json& SceneDataCache::chosen_transfer_function(const std::string& key, const Volume& volume) {
  used_.insert("t" + key);
  auto& tf = transfer_functions_[key];
  if (tf.is_null()) tf = chooser_ ? chooser_(volume) : choose_transfer_function(volume);
  return tf;
}

std::shared_ptr<const PyramidSource> SceneDataCache::pyramid(const std::string& key,
                                                            const std::function<std::shared_ptr<const PyramidSource>()>& find) {
  used_.insert("y" + key);
  auto found = pyramids_.find(key);
  if (found == pyramids_.end()) found = pyramids_.emplace(key, find()).first;
  return found->second;
}

void SceneDataCache::set_transfer_function_chooser(std::function<nlohmann::json(const Volume&)> chooser) {
  chooser_ = std::move(chooser);
  transfer_functions_.clear();
}

void SceneDataCache::for_each_volume(const std::function<void(Volume&)>& f) {
  for (auto& [key, volume] : volumes_) f(*volume);
}

void SceneDataCache::drop_unused() {
  std::erase_if(volumes_, [&](const auto& e) { return !used_.count("v" + e.first); });
  std::erase_if(transfer_functions_, [&](const auto& e) { return !used_.count("t" + e.first); });
  std::erase_if(particles_, [&](const auto& e) { return !used_.count("p" + e.first); });
  std::erase_if(trajectories_, [&](const auto& e) { return !used_.count("r" + e.first); });
  std::erase_if(frame_times_, [&](const auto& e) { return !used_.count("f" + e.first); });
  std::erase_if(particle_files_, [&](const auto& e) { return !used_.count("a" + e.first); });
  std::erase_if(selected_atoms_, [&](const auto& e) { return !used_.count("n" + e.first); });
  std::erase_if(selected_indices_, [&](const auto& e) { return !used_.count("i" + e.first); });
  std::erase_if(series_, [&](const auto& e) { return !used_.count("s" + e.first); });
  std::erase_if(pyramids_, [&](const auto& e) { return !used_.count("y" + e.first); });
  used_.clear();
}

}  // namespace penumbra
