// The .top reader's driver: the preprocessor's logical lines, each section header checked and
// each data line handed to the reader of its section (the force field's parameters in
// top_parameters.cpp, the molecule types in top_molecules.cpp), [ molecules ] checked as it is
// read (top_checks.cpp), and the System assembled at the end (top_assembly.cpp).
#include "engine/gromacs/topology.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "engine/errors.hpp"
#include "engine/gromacs/top_assembly.hpp"
#include "engine/gromacs/top_checks.hpp"
#include "engine/gromacs/top_fields.hpp"
#include "engine/gromacs/top_molecules.hpp"
#include "engine/gromacs/top_parameters.hpp"
#include "engine/gromacs/top_preprocessor.hpp"

namespace vimd {
namespace fs = std::filesystem;

namespace {

using namespace top;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

enum class Section {
  Defaults,
  AtomTypes,
  NonbondParams,
  BondTypes,
  ConstraintTypes,
  AngleTypes,
  PairTypes,
  DihedralTypes,
  IgnoredTypes,
  MoleculeType,
  Atoms,
  Bonds,
  Angles,
  Dihedrals,
  Pairs,
  Constraints,
  Settles,
  Exclusions,
  VirtualSites2,
  VirtualSites3,
  UnsupportedInteraction,
  System,
  Molecules,
};

struct SectionInfo {
  Section section;
  const char* unsupported_what = "";
};

const std::map<std::string, SectionInfo>& section_table() {
  static const std::map<std::string, SectionInfo> table = {
      {"defaults", {Section::Defaults}},
      {"atomtypes", {Section::AtomTypes}},
      {"nonbond_params", {Section::NonbondParams}},
      {"bondtypes", {Section::BondTypes}},
      {"constrainttypes", {Section::ConstraintTypes}},
      {"angletypes", {Section::AngleTypes}},
      {"pairtypes", {Section::PairTypes}},
      {"dihedraltypes", {Section::DihedralTypes}},
      // Parameter tables only matter through interactions that use them, which are refused.
      {"cmaptypes", {Section::IgnoredTypes}},
      {"implicit_genborn_params", {Section::IgnoredTypes}},
      {"implicit_surface_params", {Section::IgnoredTypes}},
      {"moleculetype", {Section::MoleculeType}},
      {"atoms", {Section::Atoms}},
      {"bonds", {Section::Bonds}},
      {"angles", {Section::Angles}},
      {"constraints", {Section::Constraints}},
      {"settles", {Section::Settles}},
      {"exclusions", {Section::Exclusions}},
      {"pairs", {Section::Pairs}},
      {"pairs_nb", {Section::UnsupportedInteraction, "nonbonded pair interactions ([ pairs_nb ])"}},
      {"dihedrals", {Section::Dihedrals}},
      {"cmap", {Section::UnsupportedInteraction, "CMAP corrections ([ cmap ])"}},
      {"position_restraints", {Section::UnsupportedInteraction, "position restraints ([ position_restraints ])"}},
      {"distance_restraints", {Section::UnsupportedInteraction, "distance restraints ([ distance_restraints ])"}},
      {"dihedral_restraints", {Section::UnsupportedInteraction, "dihedral restraints ([ dihedral_restraints ])"}},
      {"orientation_restraints",
       {Section::UnsupportedInteraction, "orientation restraints ([ orientation_restraints ])"}},
      {"angle_restraints", {Section::UnsupportedInteraction, "angle restraints ([ angle_restraints ])"}},
      {"angle_restraints_z", {Section::UnsupportedInteraction, "angle restraints ([ angle_restraints_z ])"}},
      {"polarization", {Section::UnsupportedInteraction, "polarization ([ polarization ])"}},
      {"water_polarization", {Section::UnsupportedInteraction, "water polarization ([ water_polarization ])"}},
      {"thole_polarization", {Section::UnsupportedInteraction, "Thole polarization ([ thole_polarization ])"}},
      {"virtual_sites1", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sites1 ])"}},
      {"virtual_sites2", {Section::VirtualSites2}},
      {"virtual_sites3", {Section::VirtualSites3}},
      {"virtual_sites4", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sites4 ])"}},
      {"virtual_sitesn", {Section::UnsupportedInteraction, "virtual sites ([ virtual_sitesn ])"}},
      {"dummies2", {Section::VirtualSites2}},  // the old names, still read by grompp
      {"dummies3", {Section::VirtualSites3}},
      {"dummies4", {Section::UnsupportedInteraction, "virtual sites ([ dummies4 ])"}},
      {"dummiesn", {Section::UnsupportedInteraction, "virtual sites ([ dummiesn ])"}},
      {"system", {Section::System}},
      {"molecules", {Section::Molecules}},
  };
  return table;
}

class TopologyParser {
 public:
  TopologyParser(const fs::path& top, BondConstraints bond_constraints, std::vector<std::string>& warnings)
      : top_(top), pre_(top, gromacs_library_dirs()), molecules_(parameters_, bond_constraints), warnings_(warnings) {}

  System parse() {
    LogicalLine line;
    while (pre_.next(line)) {
      if (line.text.front() == '[') {
        header(line);
        continue;
      }
      // GROMACS ignores text before the first section (AMBER and CHARMM force fields open with a
      // banner of asterisks).
      if (section_) data(line);
    }
    if (molecule_counts_.empty()) throw InputError(top_.string(), 0, "no molecules: the topology has no [ molecules ] entries");
    return assemble_system(molecules_.molecules(), molecule_counts_, parameters_, title_, warnings_);
  }

 private:
  void header(const LogicalLine& line) {
    const auto close = line.text.find(']');
    if (close == std::string::npos || !trim(std::string_view(line.text).substr(close + 1)).empty())
      fail(line.where, "malformed section header '" + line.text + "', expected e.g. [ atoms ]");
    section_name_ = lower(std::string(trim(std::string_view(line.text).substr(1, close - 1))));
    if (section_name_ == "intermolecular_interactions")
      fail(line.where, "[ intermolecular_interactions ] are not supported by vimd");
    const auto it = section_table().find(section_name_);
    if (it == section_table().end()) fail(line.where, "unknown section [ " + section_name_ + " ]");
    section_ = it->second;
    if (section_->section != Section::Defaults && !parameters_.has_defaults())
      fail(line.where, "[ " + section_name_ + " ] before [ defaults ]: the force field's [ defaults ] must come first");
    const bool molecule_level = section_->section >= Section::Atoms && section_->section <= Section::UnsupportedInteraction;
    if (molecule_level && molecules_.molecules().empty())
      fail(line.where, "[ " + section_name_ + " ] outside a [ moleculetype ]");
  }

  void data(const LogicalLine& line) {
    const Fields f(line, section_name_);
    switch (section_->section) {
      case Section::Defaults: parameters_.defaults(f); break;
      case Section::AtomTypes: parameters_.atomtype(f); break;
      case Section::NonbondParams: parameters_.nonbond_params(f); break;
      case Section::BondTypes: parameters_.bondtype(f); break;
      case Section::ConstraintTypes: parameters_.constrainttype(f); break;
      case Section::AngleTypes: parameters_.angletype(f); break;
      case Section::PairTypes: parameters_.pairtype(f); break;
      case Section::DihedralTypes: parameters_.dihedraltype(f); break;
      case Section::IgnoredTypes: break;
      case Section::MoleculeType: molecules_.moleculetype(f); break;
      case Section::Atoms: molecules_.atom(f); break;
      case Section::Bonds: molecules_.bond(f); break;
      case Section::Angles: molecules_.angle(f); break;
      case Section::Dihedrals: molecules_.dihedral(f); break;
      case Section::Pairs: molecules_.pair(f); break;
      case Section::Constraints: molecules_.constraint(f); break;
      case Section::Settles: molecules_.settle(f); break;
      case Section::Exclusions: molecules_.exclusion(f); break;
      case Section::VirtualSites2: molecules_.virtual_site(f, 2); break;
      case Section::VirtualSites3: molecules_.virtual_site(f, 3); break;
      case Section::UnsupportedInteraction:
        molecules_.unsupported(f, std::string(section_->unsupported_what) + " are not supported");
        break;
      case Section::System: title_ += (title_.empty() ? "" : " ") + line.text; break;
      case Section::Molecules: molecule_count(f); break;
    }
  }

  // A [ molecules ] line: the molecule type it uses is checked here, at its first use.
  void molecule_count(const Fields& f) {
    f.require(2, "name count");
    const auto& molecules = molecules_.molecules();
    const auto it = std::find_if(molecules.begin(), molecules.end(), [&](const auto& m) { return m.name == f[0]; });
    if (it == molecules.end()) f.error("no [ moleculetype ] named '" + f[0] + "'");
    const long count = f.integer(1, "count");
    if (count <= 0) f.error("molecule count must be positive, found " + f[1]);
    if (it->unsupported)
      fail(it->unsupported->where, "molecule type '" + it->name + "' (used in [ molecules ] at " + f.where().str() +
                                       "): " + it->unsupported->what);
    if (it->atoms.empty()) f.error("molecule type '" + it->name + "' has no atoms");
    check_sites(*it);
    check_constraint_set(*it);
    // A typo such as an extra digit must not become an attempt to allocate billions of atoms.
    constexpr long kMaxAtoms = 10'000'000;
    const long atoms = static_cast<long>(it->atoms.size());
    if (count > kMaxAtoms / atoms || total_atoms_ + count * atoms > kMaxAtoms)
      f.error("'" + it->name + " " + f[1] + "' makes the system larger than vimd's limit of " +
              std::to_string(kMaxAtoms) + " atoms (a typo in the count?)");
    total_atoms_ += count * atoms;
    molecule_counts_.push_back({static_cast<int>(it - molecules.begin()), static_cast<int>(count)});
  }

  fs::path top_;
  Preprocessor pre_;
  std::string section_name_;
  std::optional<SectionInfo> section_;
  ForceFieldParameters parameters_;
  MoleculeTypeReader molecules_;
  std::vector<MoleculeCount> molecule_counts_;
  long total_atoms_ = 0;
  std::string title_;
  std::vector<std::string>& warnings_;
};

}  // namespace
std::vector<fs::path> gromacs_library_dirs() {
  std::vector<fs::path> dirs;
  const char* gmxlib = std::getenv("GMXLIB");
  if (gmxlib && *gmxlib) {
    std::string_view rest(gmxlib);
    while (!rest.empty()) {
      const auto colon = std::min(rest.find(':'), rest.size());
      if (colon > 0) dirs.emplace_back(rest.substr(0, colon));
      rest.remove_prefix(std::min(colon + 1, rest.size()));
    }
  } else {
    dirs.emplace_back("/usr/share/gromacs/top");
  }
  return dirs;
}

bool hydrogen_like(const std::string& atom_name) {
  return !atom_name.empty() && std::toupper(static_cast<unsigned char>(atom_name[0])) == 'H';
}

System read_topology(const fs::path& top, BondConstraints bond_constraints, std::vector<std::string>* warnings) {
  std::vector<std::string> ignored;
  return TopologyParser(top, bond_constraints, warnings ? *warnings : ignored).parse();
}

}  // namespace vimd
