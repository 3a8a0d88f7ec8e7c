#pragma once
// Named arrays of doubles: what an integrator, a force term or an observer carries from step to
// step besides the State (predictor history, neighbour-list build positions, series of samples).
// Each component fills and reads its own; a checkpoint stores them without looking inside.
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/types.hpp"

namespace vimd {

struct Carried {
  std::map<std::string, std::vector<double>> items;

  bool empty() const { return items.empty(); }
  bool has(const std::string& name) const { return items.count(name) > 0; }
  void put(const std::string& name, std::vector<double> values) { items[name] = std::move(values); }
  void put(const std::string& name, double value) { items[name] = {value}; }
  void put(const std::string& name, const Coords& c) { items[name].assign(c.data(), c.data() + c.size()); }

  const std::vector<double>& values(const std::string& name) const {
    auto it = items.find(name);
    if (it == items.end()) throw std::runtime_error("checkpoint: no entry \"" + name + "\"");
    return it->second;
  }
  double number(const std::string& name) const {
    const auto& v = values(name);
    if (v.size() != 1) throw std::runtime_error("checkpoint: entry \"" + name + "\" is not a number");
    return v[0];
  }
  Coords coords(const std::string& name) const {
    const auto& v = values(name);
    if (v.size() % 3 != 0) throw std::runtime_error("checkpoint: entry \"" + name + "\" is not 3 x N");
    return Eigen::Map<const Coords>(v.data(), 3, static_cast<Eigen::Index>(v.size() / 3));
  }
};

}  // namespace vimd
