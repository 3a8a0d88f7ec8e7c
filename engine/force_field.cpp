#include "engine/force_field.hpp"

#include <limits>

namespace vimd {

void ForceField::add(std::unique_ptr<ForceTerm> term) {
  auto names = term->energy_names();
  name_counts_.push_back(names.size());
  names_.insert(names_.end(), names.begin(), names.end());
  terms_.push_back(std::move(term));
}

void ForceField::compute(const Coords& q, Forces& out) { evaluate(q, out, true); }

void ForceField::compute_forces(const Coords& q, Forces& out) { evaluate(q, out, false); }

void ForceField::evaluate(const Coords& q, Forces& out, bool energies) {
  out.f.setZero(3, q.cols());
  out.terms.assign(names_.size(), energies ? 0.0 : std::numeric_limits<double>::quiet_NaN());
  std::size_t offset = 0;
  for (std::size_t k = 0; k < terms_.size(); ++k) {
    auto& t = terms_[k];
    const std::size_t n = name_counts_[k];
    t->prepare(q);
    t->add_forces(q, out.f, energies ? std::span<double>(out.terms).subspan(offset, n) : std::span<double>());
    offset += n;
  }
  out.potential = 0;
  for (double e : out.terms) out.potential += e;
  ++force_evaluations_;
  if (single_precision_) ++single_force_evaluations_;
}

void ForceField::hessian_vector(const Coords& q, const Coords& u, Coords& out) {
  out.setZero(3, q.cols());
  for (auto& t : terms_) {
    t->prepare(q);
    t->add_hessian_vector(q, u, out);
  }
  ++hessian_evaluations_;
  if (single_precision_) ++single_hessian_evaluations_;
}

void ForceField::fix_pair_set(const Coords* q) {
  for (auto& t : terms_) t->fix_pair_set(q);
}

void ForceField::set_single_precision(bool on) {
  for (auto& t : terms_) t->set_single_precision(on);
  single_precision_ = on && has_single_precision();
}

bool ForceField::has_single_precision() const {
  for (const auto& t : terms_)
    if (t->has_single_precision()) return true;
  return false;
}

long ForceField::neighbor_rebuilds() const {
  long n = 0;
  for (const auto& t : terms_) n += t->rebuilds();
  return n;
}

long ForceField::neighbor_prunes() const {
  long n = 0;
  for (const auto& t : terms_) n += t->prunes();
  return n;
}

double ForceField::neighbor_build_seconds() const {
  double s = 0;
  for (const auto& t : terms_) s += t->rebuild_seconds();
  return s;
}

Carried ForceField::save() const {
  Carried out;
  for (std::size_t k = 0; k < terms_.size(); ++k) {
    Carried term;
    terms_[k]->save(term);
    for (auto& [name, values] : term.items) out.items[std::to_string(k) + "/" + name] = std::move(values);
  }
  return out;
}

void ForceField::restore(const Carried& in) {
  for (std::size_t k = 0; k < terms_.size(); ++k) {
    const std::string prefix = std::to_string(k) + "/";
    Carried term;
    for (const auto& [name, values] : in.items)
      if (name.starts_with(prefix)) term.items[name.substr(prefix.size())] = values;
    terms_[k]->restore(term);
  }
}

}  // namespace vimd
