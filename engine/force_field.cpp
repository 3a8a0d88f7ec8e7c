#include "engine/force_field.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace vimd {

namespace {

void set_zero(Coords& x, Eigen::Index n_atoms) {
  x.resize(3, n_atoms);
  double* p = x.data();
#pragma omp parallel for schedule(static) if (n_atoms >= kParallelMinAtoms)
  for (Eigen::Index i = 0; i < n_atoms; ++i) p[3 * i] = p[3 * i + 1] = p[3 * i + 2] = 0;
}

}  // namespace

int first_non_finite(const Coords& q) {
  for (Eigen::Index i = 0; i < q.cols(); ++i)
    if (!q.col(i).allFinite()) return static_cast<int>(i);
  return -1;
}

std::string position_text(const Coords& q, int i) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", q(0, i), q(1, i), q(2, i));
  return buf;
}

void ForceField::add(std::unique_ptr<ForceTerm> term) {
  auto names = term->energy_names();
  const auto part_of = term->energy_part_of();
  for (std::size_t k = 0; k < part_of.size(); ++k) {
    if (part_of[k].empty()) continue;
    const auto total = std::find(names_.begin(), names_.end(), part_of[k]);
    if (total == names_.end())
      throw std::logic_error("energy '" + names[k] + "' is a part of '" + part_of[k] + "', which no earlier term reports");
    parts_.push_back({names_.size() + k, static_cast<std::size_t>(total - names_.begin())});
  }
  name_counts_.push_back(names.size());
  for (std::size_t k = 0; k < names.size(); ++k) is_part_.push_back(k < part_of.size() && !part_of[k].empty());
  names_.insert(names_.end(), names.begin(), names.end());
  terms_.push_back(std::move(term));
}

void ForceField::compute(const Coords& q, Forces& out, const Evaluation& how) { evaluate(q, out, true, how); }

void ForceField::compute_forces(const Coords& q, Forces& out, const Evaluation& how) {
  evaluate(q, out, false, how);
}

TermEvaluation ForceField::for_term(std::size_t k, const Evaluation& how, ForceMasks* keep) const {
  TermEvaluation t;
  t.single_precision = how.single_precision;
  if (how.step && k < how.step->terms_.size()) t.step = how.step->terms_[k].get();
  if (keep) t.keep_masks = &keep->terms_[k];
  if (how.masks && k < how.masks->terms_.size()) t.masks = &how.masks->terms_[k];
  return t;
}

const Coords& ForceField::with_sites(const Coords& q) {
  if (!sites_) return q;
  placed_ = q;
  sites_->place(placed_);
  return placed_;
}

void ForceField::place_sites(Coords& q, Coords& v) const {
  if (!sites_) return;
  sites_->place(q);
  if (v.cols() == q.cols()) sites_->tangent(q, v);
}

void ForceField::evaluate(const Coords& q_atoms, Forces& out, bool energies, const Evaluation& how) {
  const Coords& q = with_sites(q_atoms);
  const bool first_writes = !terms_.empty() && terms_.front()->writes_forces();
  if (first_writes)
    out.f.resize(3, q.cols());
  else
    set_zero(out.f, q.cols());
  out.terms.assign(names_.size(), energies ? 0.0 : std::numeric_limits<double>::quiet_NaN());
  ForceMasks* keep = how.keep_masks ? &out.masks : nullptr;
  if (keep) keep->terms_.resize(terms_.size());
  std::size_t offset = 0;
  for (std::size_t k = 0; k < terms_.size(); ++k) {
    const std::size_t n = name_counts_[k];
    if (keep) keep->terms_[k].list_id = -1;
    TermEvaluation term_how = for_term(k, how, keep);
    term_how.forces_unset = k == 0 && first_writes;
    terms_[k]->add_forces(q, out.f, energies ? std::span<double>(out.terms).subspan(offset, n) : std::span<double>(),
                          term_how);
    offset += n;
  }
  if (sites_) sites_->spread(q, out.f);
  total_energies(out);
  ++evaluations_.force_evaluations;
  if (how.single_precision && has_single_precision()) ++evaluations_.single_precision_force_evaluations;
}

void ForceField::hessian_vector(const Coords& q_atoms, const Coords& u_atoms, Coords& out, const Evaluation& how) {
  const Coords& q = with_sites(q_atoms);
  if (sites_) {
    tangent_ = u_atoms;
    sites_->tangent(q, tangent_);
  }
  const Coords& u = sites_ ? tangent_ : u_atoms;
  set_zero(out, q.cols());
  for (std::size_t k = 0; k < terms_.size(); ++k) terms_[k]->add_hessian_vector(q, u, out, for_term(k, how, nullptr));
  if (sites_) {
    const Coords* site_forces = nullptr;
    if (!sites_->linear()) {  // the curvature of the constructions needs the forces on the sites
      site_forces_.setZero(3, q.cols());
      const Evaluation forces_only{how.single_precision, how.step};
      for (std::size_t k = 0; k < terms_.size(); ++k)
        terms_[k]->add_forces(q, site_forces_, {}, for_term(k, forces_only, nullptr));
      site_forces = &site_forces_;
      ++evaluations_.force_evaluations;  // a real cost of this product
    }
    sites_->spread_hessian(q, u, site_forces, out);
  }
  ++evaluations_.hessian_evaluations;
  if (how.single_precision && has_single_precision()) ++evaluations_.single_precision_hessian_evaluations;
}

void ForceField::single_point(const Coords& q_atoms, Forces& out) const {
  if (const int bad = first_non_finite(q_atoms); bad >= 0)
    throw std::invalid_argument("no energy or forces at non-finite positions: atom " + std::to_string(bad + 1) +
                                " is at " + position_text(q_atoms, bad));
  Coords placed;
  if (sites_) {
    placed = q_atoms;
    sites_->place(placed);
  }
  const Coords& q = sites_ ? placed : q_atoms;
  out.f.setZero(3, q.cols());
  out.terms.assign(names_.size(), 0.0);
  std::size_t offset = 0;
  for (std::size_t k = 0; k < terms_.size(); ++k) {
    terms_[k]->add_single_point(q, out.f, std::span<double>(out.terms).subspan(offset, name_counts_[k]));
    offset += name_counts_[k];
  }
  if (sites_) sites_->spread(q, out.f);
  total_energies(out);
}

void ForceField::total_energies(Forces& out) const {
  for (const EnergyPart& p : parts_) out.terms[p.total] += out.terms[p.part];
  out.potential = 0;
  for (std::size_t k = 0; k < out.terms.size(); ++k)
    if (!is_part_[k]) out.potential += out.terms[k];
}

void ForceField::start_step(StepPairSet& pairs, const Coords& q_atoms) {
  const Coords& q = with_sites(q_atoms);
  pairs.terms_.resize(terms_.size());
  for (std::size_t k = 0; k < terms_.size(); ++k) terms_[k]->start_step(q, pairs.terms_[k]);
}

bool ForceField::has_single_precision() const {
  for (const auto& t : terms_)
    if (t->has_single_precision()) return true;
  return false;
}

WorkCounters ForceField::work() const {
  WorkCounters w = evaluations_;
  for (const auto& t : terms_) t->add_work(w);
  return w;
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
