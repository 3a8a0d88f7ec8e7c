#pragma once
// The force field's parameters as the topology defines them: [ defaults ] and the [ *types ]
// sections (and [ nonbond_params ]), read line by line, and the lookups the molecule sections
// make in them, which fail at the molecule's line when nothing matches (as grompp).
#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "engine/gromacs/top_fields.hpp"
#include "engine/gromacs/top_model.hpp"

namespace vimd::top {

// GROMACS's dihedral function types: the parameter table a type's [ dihedraltypes ] go to (9
// shares type 1's), and the number of A- and B-state parameters.
struct DihedralFunction {
  int table;
  std::size_t n_a, n_b;
  const char* layout;
};

std::optional<DihedralFunction> dihedral_function(long func);

// Dihedral function types GROMACS has but vimd does not compute: tabulated, restricted, CBT.
bool dihedral_function_unsupported(long func);

// Parameters from field `first` on: n_a A-state values, optionally followed by n_b B-state ones
// (which, differing from the A state's first n_b, mark free-energy perturbation). Empty if none.
std::pair<std::vector<double>, bool> dihedral_parameters(const Fields& f, std::size_t first,
                                                         const DihedralFunction& function);

class ForceFieldParameters {
 public:
  // The section readers, one data line each.
  void defaults(const Fields& f);
  void atomtype(const Fields& f);
  void nonbond_params(const Fields& f);
  void bondtype(const Fields& f);
  void constrainttype(const Fields& f);
  void angletype(const Fields& f);
  void pairtype(const Fields& f);
  void dihedraltype(const Fields& f);

  // Whether [ defaults ] has been read (every other section must come after it).
  bool has_defaults() const { return comb_rule_.has_value(); }
  double fudge_qq() const { return fudge_qq_; }

  const std::vector<AtomType>& atomtypes() const { return atomtypes_; }
  // The atom type named in field k, or an error at f's line.
  const AtomType& atomtype_named(const Fields& f, std::size_t k) const;
  int index_of(const AtomType& type) const { return atomtype_index_.at(type.name); }

  // The lookups of a molecule's line f in the tables, by bonded type names; an error at f's line
  // when there is no entry.
  std::vector<double> bond_parameters(const Fields& f, const std::string& a, const std::string& b) const;
  std::vector<double> angle_parameters(const Fields& f, const std::string& a, const std::string& b,
                                       const std::string& c) const;
  std::vector<double> constraint_parameters(const Fields& f, long func, const std::string& a,
                                            const std::string& b) const;
  // A 1–4 pair's c6, c12 without parameters of its own: the [ pairtypes ] of its atom types, else
  // (with gen-pairs) fudgeLJ times the pair's normal LJ, as grompp.
  std::pair<double, double> pair14_lennard_jones(const Fields& f, const AtomType& a, const AtomType& b) const;
  // grompp's defaultInteractionsOfType for dihedrals (see the definition).
  std::vector<const DihedralType*> find_dihedraltypes(int table, const std::array<std::string, 4>& names) const;

  // c6, c12 from V, W as the combination rule reads them.
  std::pair<double, double> lj_coefficients(double v, double w) const;
  // c6, c12 of two atom types: [ nonbond_params ], else the combination rule.
  std::pair<double, double> lennard_jones(const AtomType& a, const AtomType& b) const;

 private:
  using TypePair = std::pair<std::string, std::string>;
  using Pair = std::pair<double, double>;

  std::optional<int> comb_rule_;
  Where defaults_where_;
  bool gen_pairs_ = false;
  double fudge_lj_ = 1, fudge_qq_ = 1;
  std::set<std::string> bonded_names_;
  std::vector<AtomType> atomtypes_;
  std::unordered_map<std::string, int> atomtype_index_;
  std::map<TypePair, std::pair<Pair, Where>> nonbond_params_, bondtypes_, pairtypes_;
  std::map<std::pair<int, TypePair>, std::pair<double, Where>> constrainttypes_;
  std::map<std::array<std::string, 3>, std::pair<Pair, Where>> angletypes_;
  std::map<int, std::vector<DihedralType>> dihedraltypes_;  // by DihedralFunction::table
};

}  // namespace vimd::top
