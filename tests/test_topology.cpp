#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <numbers>
#include <optional>
#include <sstream>
#include <tuple>

#include "engine/errors.hpp"
#include "engine/gromacs/topology.hpp"
#include "marked_line.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {

const fs::path kData = fs::path(VIMD_SOURCE_DIR) / "tests/data";
const fs::path kTop = kData / "top";

double deg(double d) { return d * std::numbers::pi / 180.0; }

// c6, c12 from sigma, epsilon: 4ε σ⁶ and 4ε σ¹².
double c6_of(double sigma, double eps) { return 4 * eps * std::pow(sigma, 6); }
double c12_of(double sigma, double eps) { return 4 * eps * std::pow(sigma, 12); }

// Sets an environment variable for one scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_) setenv(name_, old_->c_str(), 1);
    else unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

void expect_exclusions_consistent(const System& s) {
  ASSERT_EQ(static_cast<int>(s.exclusions.size()), s.n_atoms());
  for (int i = 0; i < s.n_atoms(); ++i) {
    EXPECT_TRUE(std::is_sorted(s.exclusions[i].begin(), s.exclusions[i].end()));
    for (int j : s.exclusions[i]) {
      EXPECT_NE(i, j);
      EXPECT_TRUE(std::binary_search(s.exclusions[j].begin(), s.exclusions[j].end(), i)) << i << " " << j;
    }
  }
}

}  // namespace

TEST(Topology, LoadsStandardOplsSpce) {
  ScopedEnv no_gmxlib("GMXLIB", "");
  const System s = read_topology(kTop / "spce_opls.top");
  EXPECT_EQ(s.title, "Two SPC/E waters");
  ASSERT_EQ(s.n_atoms(), 6);
  EXPECT_EQ(s.atom_names, (std::vector<std::string>{"OW", "HW1", "HW2", "OW", "HW1", "HW2"}));
  EXPECT_EQ(s.residue_names[4], "SOL");
  EXPECT_EQ(s.residue_numbers, (std::vector<int>{1, 1, 1, 2, 2, 2}));
  EXPECT_EQ(s.molecule, (std::vector<int>{0, 0, 0, 1, 1, 1}));
  for (int w = 0; w < 2; ++w) {
    EXPECT_DOUBLE_EQ(s.mass[3 * w], 15.9994);  // opls_116 without HEAVY_H
    EXPECT_DOUBLE_EQ(s.mass[3 * w + 1], 1.008);
    EXPECT_DOUBLE_EQ(s.charge[3 * w], -0.8476);  // spce.itp overrides the atom type's -0.82
    EXPECT_DOUBLE_EQ(s.charge[3 * w + 2], 0.4238);
  }
  EXPECT_EQ(s.type_names, (std::vector<std::string>{"opls_116", "opls_117"}));
  EXPECT_EQ(s.type, (std::vector<int>{0, 1, 1, 0, 1, 1}));
  // OPLS uses comb-rule 3; opls_116 has sigma 0.316557 nm, epsilon 0.650194 kJ/mol.
  EXPECT_NEAR(s.c6(0, 0), c6_of(0.316557, 0.650194), 1e-15);
  EXPECT_NEAR(s.c12(0, 0), c12_of(0.316557, 0.650194), 1e-18);
  // OPLS's rounded sigma/epsilon reproduce the SPC/E c6/c12 of GROMACS's GROMOS files to 3e-4.
  EXPECT_NEAR(s.c6(0, 0), 0.0026173456, 5e-4 * 0.0026173456);
  EXPECT_NEAR(s.c12(0, 0), 2.634129e-6, 5e-4 * 2.634129e-6);
  EXPECT_EQ(s.c6(0, 1), 0.0);
  EXPECT_EQ(s.c12(1, 1), 0.0);
  EXPECT_TRUE(s.bonds.empty());
  EXPECT_TRUE(s.angles.empty());
  ASSERT_EQ(s.constraints.size(), 6u);  // settles -> O-H1, O-H2, H1-H2 per water
  const std::vector<std::tuple<int, int, double>> expected = {{0, 1, 0.1}, {0, 2, 0.1}, {1, 2, 0.16330},
                                                              {3, 4, 0.1}, {3, 5, 0.1}, {4, 5, 0.16330}};
  for (std::size_t c = 0; c < expected.size(); ++c) {
    EXPECT_EQ(s.constraints[c].i, std::get<0>(expected[c]));
    EXPECT_EQ(s.constraints[c].j, std::get<1>(expected[c]));
    EXPECT_DOUBLE_EQ(s.constraints[c].length, std::get<2>(expected[c]));
  }
  EXPECT_EQ(s.exclusions[0], (std::vector<int>{1, 2}));
  EXPECT_EQ(s.exclusions[1], (std::vector<int>{0, 2}));
  EXPECT_EQ(s.exclusions[5], (std::vector<int>{3, 4}));
  expect_exclusions_consistent(s);
  EXPECT_EQ(s.box.length, Vec3::Zero());
  EXPECT_EQ(s.degrees_of_freedom(), 18 - 6);  // no box yet, so no centre-of-mass correction
}

TEST(Topology, FlexibleDefineSelectsBondsAndAngle) {
  ScopedEnv no_gmxlib("GMXLIB", "");
  const System s = read_topology(kTop / "spce_opls_flexible.top");
  EXPECT_TRUE(s.constraints.empty());
  ASSERT_EQ(s.bonds.size(), 4u);
  EXPECT_EQ(s.bonds[1].i, 0);
  EXPECT_EQ(s.bonds[1].j, 2);
  EXPECT_DOUBLE_EQ(s.bonds[1].length, 0.1);
  EXPECT_DOUBLE_EQ(s.bonds[1].k, 345000);
  ASSERT_EQ(s.angles.size(), 2u);
  EXPECT_EQ(s.angles[1].i, 4);
  EXPECT_EQ(s.angles[1].j, 3);
  EXPECT_EQ(s.angles[1].k, 5);
  EXPECT_NEAR(s.angles[1].theta0, deg(109.47), 1e-15);
  EXPECT_DOUBLE_EQ(s.angles[1].force_constant, 383);
  // nrexcl 2 along the two O-H bonds excludes H1-H2 without [ exclusions ].
  EXPECT_EQ(s.exclusions[4], (std::vector<int>{3, 5}));
  expect_exclusions_consistent(s);
}

TEST(Topology, ChainWithTypedParametersExclusionsAndResidues) {
  const System s = read_topology(kTop / "chain.top");
  EXPECT_EQ(s.title, "Chain and ions");
  ASSERT_EQ(s.n_atoms(), 7);
  EXPECT_EQ(s.molecule, (std::vector<int>{0, 0, 0, 0, 0, 1, 2}));
  // The chain has two residues and keeps its numbers; single-residue ions continue after them.
  EXPECT_EQ(s.residue_numbers, (std::vector<int>{1, 1, 2, 2, 2, 3, 4}));
  EXPECT_EQ(s.residue_names[5], "ION");
  EXPECT_EQ(s.atom_names[2], "C3");
  // Masses and charges from [ atoms ], else from the atom type.
  const std::vector<double> mass = {12.011, 14.027, 13.019, 14.027, 15.035, 15.035, 15.035};
  const std::vector<double> charge = {0.10, -0.10, 0.0, -0.10, -0.25, 0.25, 0.25};
  for (int i = 0; i < 7; ++i) {
    EXPECT_DOUBLE_EQ(s.mass[i], mass[i]) << i;
    EXPECT_DOUBLE_EQ(s.charge[i], charge[i]) << i;
  }
  // Types in order of first use; all four [ atomtypes ] column layouts.
  EXPECT_EQ(s.type_names, (std::vector<std::string>{"CA", "CB", "CD", "CC"}));
  EXPECT_EQ(s.type, (std::vector<int>{0, 1, 2, 1, 3, 3, 3}));
  const double sigma[] = {0.34, 0.39, 0.38, 0.30}, eps[] = {0.36, 0.40, 0.20, 0.50};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      double sig = 0.5 * (sigma[a] + sigma[b]), ep = std::sqrt(eps[a] * eps[b]);  // Lorentz-Berthelot
      if ((a == 0 && b == 3) || (a == 3 && b == 0)) sig = 0.31, ep = 0.45;       // [ nonbond_params ]
      EXPECT_NEAR(s.c6(a, b), c6_of(sig, ep), 1e-15) << a << b;
      EXPECT_NEAR(s.c12(a, b), c12_of(sig, ep), 1e-18) << a << b;
    }
  // Bonds: CA-CX and CX-CX from [ bondtypes ] via bonded types, the third inline.
  ASSERT_EQ(s.bonds.size(), 3u);
  EXPECT_DOUBLE_EQ(s.bonds[0].length, 0.153);
  EXPECT_DOUBLE_EQ(s.bonds[0].k, 250000);
  EXPECT_DOUBLE_EQ(s.bonds[1].length, 0.154);
  EXPECT_DOUBLE_EQ(s.bonds[1].k, 200000);
  EXPECT_EQ(s.bonds[2].i, 2);
  EXPECT_EQ(s.bonds[2].j, 3);
  EXPECT_DOUBLE_EQ(s.bonds[2].length, 0.16);
  EXPECT_DOUBLE_EQ(s.bonds[2].k, 1000);
  ASSERT_EQ(s.constraints.size(), 2u);
  EXPECT_DOUBLE_EQ(s.constraints[0].length, 0.155);  // [ constrainttypes ] CX CC 1, not the type-2 entry
  EXPECT_EQ(s.constraints[1].i, 0);
  EXPECT_EQ(s.constraints[1].j, 3);
  EXPECT_DOUBLE_EQ(s.constraints[1].length, 0.30);
  ASSERT_EQ(s.angles.size(), 2u);
  EXPECT_EQ(s.angles[0].j, 1);
  EXPECT_NEAR(s.angles[0].theta0, deg(111.0), 1e-15);
  EXPECT_DOUBLE_EQ(s.angles[0].force_constant, 400);
  EXPECT_NEAR(s.angles[1].theta0, deg(109.5), 1e-15);
  // nrexcl 2 along bonds and the type-1 constraint 4-5; the type-2 constraint 1-4 adds nothing;
  // [ exclusions ] 1 5 adds 1-5.
  EXPECT_EQ(s.exclusions[0], (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(s.exclusions[1], (std::vector<int>{0, 2, 3}));
  EXPECT_EQ(s.exclusions[2], (std::vector<int>{0, 1, 3, 4}));
  EXPECT_EQ(s.exclusions[3], (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(s.exclusions[4], (std::vector<int>{0, 2, 3}));
  EXPECT_TRUE(s.exclusions[5].empty());
  expect_exclusions_consistent(s);
}

TEST(Topology, CombinationRuleOneUsesC6C12Geometrically) {
  const System s = read_topology(kTop / "comb1.top");
  EXPECT_DOUBLE_EQ(s.c6(0, 0), 0.0026);
  EXPECT_DOUBLE_EQ(s.c12(1, 1), 4.0e-6);
  EXPECT_DOUBLE_EQ(s.c6(0, 1), 0.0031);  // [ nonbond_params ]
  EXPECT_DOUBLE_EQ(s.c12(1, 0), 3.1e-6);
}

TEST(Topology, CombinationRuleThreeIsGeometricAndNegativeSigmaZeroesC6) {
  const System s = read_topology(kTop / "comb3.top");
  EXPECT_NEAR(s.c6(0, 0), c6_of(0.30, 0.50), 1e-15);
  EXPECT_NEAR(s.c12(0, 0), c12_of(0.30, 0.50), 1e-18);
  EXPECT_EQ(s.c6(1, 1), 0.0);
  EXPECT_NEAR(s.c12(1, 1), c12_of(0.40, 0.20), 1e-18);
  EXPECT_EQ(s.c6(0, 1), 0.0);
  EXPECT_NEAR(s.c12(0, 1), c12_of(std::sqrt(0.30 * 0.40), std::sqrt(0.50 * 0.20)), 1e-18);
}

TEST(Topology, IfdefBranchesMacrosAndContinuation) {
  const System s = read_topology(kTop / "dimer_ifdef.top");
  ASSERT_EQ(s.n_atoms(), 6);
  EXPECT_TRUE(s.bonds.empty());  // #else branch and the #undef'ed block are skipped
  ASSERT_EQ(s.constraints.size(), 3u);
  for (const auto& c : s.constraints) EXPECT_DOUBLE_EQ(c.length, 0.2);  // DIMER_LENGTH substituted
  EXPECT_EQ(s.constraints[2].i, 4);
  std::istringstream title(s.title);
  std::vector<std::string> words{std::istream_iterator<std::string>(title), {}};
  EXPECT_EQ(words, (std::vector<std::string>{"Dimer", "with", "continuation"}));

  const System b = read_topology(kTop / "dimer_bond.top");
  ASSERT_EQ(b.bonds.size(), 1u);
  EXPECT_DOUBLE_EQ(b.bonds[0].length, 0.2);
  EXPECT_DOUBLE_EQ(b.bonds[0].k, 5000.0);
  EXPECT_TRUE(b.constraints.empty());
}

TEST(Topology, GmxlibOverridesTheDataDirectory) {
  {
    ScopedEnv env("GMXLIB", (kData / "gmxlib").string());
    const System s = read_topology(kTop / "gmxlib.top");
    ASSERT_EQ(s.n_atoms(), 1);
    EXPECT_DOUBLE_EQ(s.mass[0], 42.0);
    EXPECT_DOUBLE_EQ(s.charge[0], 0.5);
  }
  {
    ScopedEnv env("GMXLIB", "/nonexistent:" + (kData / "gmxlib").string());
    EXPECT_EQ(gromacs_library_dirs(), (std::vector<fs::path>{"/nonexistent", kData / "gmxlib"}));
    EXPECT_EQ(read_topology(kTop / "gmxlib.top").n_atoms(), 1);
  }
  {
    ScopedEnv env("GMXLIB", "");
    EXPECT_EQ(gromacs_library_dirs(), (std::vector<fs::path>{"/usr/share/gromacs/top"}));
    try {
      read_topology(kTop / "gmxlib.top");
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), 2);
      EXPECT_NE(std::string(e.what()).find("gmxlib.top:2: cannot find #include \"mini.ff/forcefield.itp\""),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(Topology, MalformedInputsNameFileAndLine) {
  struct Case {
    const char* top;
    const char* marked;  // the file whose "; ERROR" line the error must name
    const char* problem;
  };
  const Case cases[] = {
      {"bad_number.top", "bad_number.top", "(parameter) is not a number: '0.1x'"},
      {"unknown_section.top", "unknown_section.top", "unknown section [ atomz ]"},
      {"pairs_nb_used.top", "pairs_nb_used.top", "nonbonded pair interactions ([ pairs_nb ]) are not supported"},
      {"dihedral_tabulated.top", "dihedral_tabulated.top", "dihedral function type 8 is not supported"},
      {"dihedral_no_type.top", "dihedral_no_type.top",
       "no [ dihedraltypes ] entry of function 5 matches the bonded types CA CX CX CC of atoms 1 (A1), 2 (A2), 3 (A3), "
       "4 (A4)"},
      {"dihedral_unknown_function.top", "dihedral_unknown_function.top", "dihedral function type 7 does not exist"},
      {"dihedral_bad_multiplicity.top", "dihedral_bad_multiplicity.top", "multiplicity 2.5 is not an integer"},
      {"dihedraltype_second_block.top", "dihedraltype_second_block.top",
       "a second block of [ dihedraltypes ] function 9 lines for CA CX CX CA"},
      {"dihedraltype_redefined.top", "dihedraltype_redefined.top",
       "[ dihedraltypes ] CA CX CX CA redefined with different parameters"},
      {"dihedraltype_unknown_bonded_type.top", "dihedraltype_unknown_bonded_type.top", "unknown bonded type 'QQ'"},
      {"pair_no_type.top", "pair_no_type.top",
       "no parameters for this 1-4 pair: no [ pairtypes ] entry CA CA 1, and [ defaults ] (at "},
      {"pair_unknown_function.top", "pair_unknown_function.top", "pair function type 3 does not exist"},
      {"morse_used.top", "morse_used.top", "bond function type 3 is not supported"},
      {"vsite_used.top", "vsite_used.top", "particle type D"},
      {"posres_active.top", "posres_active.top", "position restraints"},
      {"missing_molecule.top", "missing_molecule.top", "no [ moleculetype ] named 'WATER'"},
      {"zero_count.top", "zero_count.top", "molecule count must be positive"},
      {"unknown_atomtype.top", "unknown_atomtype.top", "unknown atom type 'CZ'"},
      {"atom_out_of_range.top", "atom_out_of_range.top", "atom number 3 is out of range"},
      {"missing_bondtype.top", "missing_bondtype.top", "no [ bondtypes ] entry CC CC 1"},
      {"include_bad_line.top", "bad_line.itp", "(residue number) is not an integer: 'one'"},
      {"missing_include.top", "missing_include.top", "cannot find #include \"no_such_file.itp\""},
      {"unclosed_ifdef.top", "unclosed_ifdef.top", "not closed by an #endif"},
      {"else_without_ifdef.top", "else_without_ifdef.top", "#else without a matching #ifdef"},
      {"unknown_directive.top", "unknown_directive.top", "unsupported preprocessor directive '#if'"},
      {"atomtypes_before_defaults.top", "atomtypes_before_defaults.top", "before [ defaults ]"},
      {"bad_comb_rule.top", "bad_comb_rule.top", "comb-rule 4 is not one of 1, 2, 3"},
      {"nonconsecutive_atoms.top", "nonconsecutive_atoms.top", "numbered consecutively: expected 2, found 3"},
      {"atoms_outside_molecule.top", "atoms_outside_molecule.top", "outside a [ moleculetype ]"},
      {"redefined_atomtype.top", "redefined_atomtype.top", "'CA' redefined with different parameters (first defined at"},
      {"too_few_fields.top", "too_few_fields.top", "expected at least 4"},
      {"settles_extra_field.top", "settles_extra_field.top",
       "settles takes OW funct doh dhh: found 3 parameters after the function type, expected 2"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.top);
    const fs::path marked = kTop / "bad" / c.marked;
    const int line = marked_line(marked, "; ERROR");
    try {
      read_topology(kTop / "bad" / c.top);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.line(), line) << what;
      EXPECT_EQ(fs::path(e.file()).filename(), c.marked) << what;
      EXPECT_NE(what.find(std::string(c.marked) + ":" + std::to_string(line) + ": "), std::string::npos) << what;
      EXPECT_NE(what.find(c.problem), std::string::npos) << what;
    }
  }
}

TEST(Topology, UnsupportedEntryNamesTheMoleculesLineToo) {
  try {
    read_topology(kTop / "bad/pairs_nb_used.top");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("molecule type 'D' (used in [ molecules ] at "), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("pairs_nb_used.top:13)"), std::string::npos) << e.what();
  }
}

TEST(Topology, EmptyMoleculesIsAnError) {
  try {
    read_topology(kTop / "bad/no_molecules.top");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 0);
    EXPECT_NE(std::string(e.what()).find("no_molecules.top: no molecules"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_topology(kTop / "no_such.top"), InputError);
}

TEST(Topology, DihedralTypesAreLookedUpAsGromppDoes) {
  const System s = read_topology(kTop / "torsions.top");
  ASSERT_EQ(s.n_atoms(), 14);
  const auto rb = [](double c) { return std::array<double, 6>{c, c, c, c, c, c}; };
  // Fourier F1..F4 = 1, 2, 3, 4 as Ryckaert-Bellemans coefficients (grompp's conversion).
  const std::array<double, 6> fourier{2 + 0.5 * (1 + 3), 0.5 * (3 * 3 - 1), 4 * 4 - 2, -2 * 3, -4 * 4, 0};
  const std::vector<std::array<double, 6>> expected_rb = {rb(2), rb(3), rb(3), fourier, fourier};
  ASSERT_EQ(s.rb_dihedrals.size(), 2 * expected_rb.size());
  for (std::size_t n = 0; n < expected_rb.size(); ++n) {
    EXPECT_EQ(s.rb_dihedrals[n].c, expected_rb[n]) << n;
    EXPECT_EQ(s.rb_dihedrals[n + expected_rb.size()].c, expected_rb[n]) << n;
  }
  EXPECT_EQ(std::tie(s.rb_dihedrals[1].i, s.rb_dihedrals[1].j, s.rb_dihedrals[1].k, s.rb_dihedrals[1].l),
            std::make_tuple(3, 2, 1, 0));
  EXPECT_EQ(s.rb_dihedrals[5].i, 7);  // the second molecule's atoms
  // Periodic: (phi_s in degrees, k, multiplicity); the type-9 block gives three terms, to function 1
  // and 9 alike.
  const std::vector<std::tuple<double, double, int>> expected_proper = {
      {0, 7, 2}, {0, 1, 1}, {180, 2, 2}, {0, 3, 3}, {0, 1, 1}, {180, 2, 2}, {0, 3, 3}, {0, 5, 3}, {180, 10, 2}};
  ASSERT_EQ(s.proper_dihedrals.size(), 2 * expected_proper.size());
  for (std::size_t n = 0; n < expected_proper.size(); ++n) {
    const PeriodicDihedral& d = s.proper_dihedrals[n];
    EXPECT_NEAR(d.phi_s, deg(std::get<0>(expected_proper[n])), 1e-15) << n;
    EXPECT_EQ(d.force_constant, std::get<1>(expected_proper[n])) << n;
    EXPECT_EQ(d.multiplicity, std::get<2>(expected_proper[n])) << n;
  }
  EXPECT_EQ(std::tie(s.proper_dihedrals[4].i, s.proper_dihedrals[4].l), std::make_tuple(6, 4));
  ASSERT_EQ(s.harmonic_impropers.size(), 2u);
  EXPECT_NEAR(s.harmonic_impropers[0].xi0, deg(10), 1e-15);
  EXPECT_EQ(s.harmonic_impropers[0].force_constant, 40);
  EXPECT_EQ(std::tie(s.harmonic_impropers[0].i, s.harmonic_impropers[0].l), std::make_tuple(4, 3));
  ASSERT_EQ(s.periodic_impropers.size(), 2u);
  EXPECT_NEAR(s.periodic_impropers[0].phi_s, deg(180), 1e-15);
  EXPECT_EQ(s.periodic_impropers[0].force_constant, 10);
  EXPECT_EQ(s.periodic_impropers[0].multiplicity, 2);
}

TEST(Topology, PairsFromGenPairsPairTypesAndInlineWithFudgeQQ) {
  const System s = read_topology(kTop / "torsions.top");
  ASSERT_EQ(s.pairs14.size(), 6u);
  const double sigma_hn = std::sqrt(0.25 * 0.32), eps_hn = std::sqrt(0.12 * 0.70);
  EXPECT_NEAR(s.pairs14[0].c6, 0.5 * c6_of(sigma_hn, eps_hn), 1e-18);  // generated: fudgeLJ 0.5
  EXPECT_NEAR(s.pairs14[0].c12, 0.5 * c12_of(sigma_hn, eps_hn), 1e-21);
  EXPECT_NEAR(s.pairs14[0].qq, 0.8 * 0.05 * -0.20, 1e-16);  // fudgeQQ 0.8
  EXPECT_NEAR(s.pairs14[1].c6, c6_of(0.31, 0.5), 1e-18);     // [ pairtypes ]: no fudge
  EXPECT_NEAR(s.pairs14[1].c12, c12_of(0.31, 0.5), 1e-21);
  EXPECT_NEAR(s.pairs14[1].qq, 0.8 * -0.10 * -0.10, 1e-16);
  EXPECT_NEAR(s.pairs14[2].c6, c6_of(0.30, 0.40), 1e-18);  // inline
  EXPECT_NEAR(s.pairs14[2].c12, c12_of(0.30, 0.40), 1e-21);
  EXPECT_EQ(std::tie(s.pairs14[3].i, s.pairs14[3].j), std::make_tuple(7, 10));
}

// grompp 2022 takes no exclusions from [ settles ] (nrexcl counts along bonds and type-1
// constraints only): three SPC/E waters without [ exclusions ] give gmx_d mdrun -rerun a Coulomb (SR)
// of -2541.57 kJ/mol, with them -1.13; vimd reads the same topology the same way.
TEST(Topology, SettlesGenerateNoExclusionsAsGrompp) {
  ScopedEnv no_gmxlib("GMXLIB", "");
  std::vector<std::string> warnings;
  const System s = read_topology(kTop / "settles_no_exclusions.top", BondConstraints::none, &warnings);
  ASSERT_EQ(s.n_atoms(), 6);
  EXPECT_EQ(s.constraints.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_TRUE(s.exclusions[i].empty()) << "atom " << i;
  // Warned once for the molecule type, at the settles line.
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("settles_no_exclusions.top:11: the settled pairs 1-2, 1-3, 2-3 of molecule type 'W' are "
                             "not in [ exclusions ]"),
            std::string::npos)
      << warnings[0];
  // The standard water model lists them itself.
  std::vector<std::string> none;
  const System spce = read_topology(kTop / "spce_opls.top", BondConstraints::none, &none);
  EXPECT_EQ(spce.exclusions[0], (std::vector<int>{1, 2}));
  EXPECT_TRUE(none.empty());
}

TEST(Topology, NrexclThreeExcludesUpToThreeBondsAway) {
  const System s = read_topology(kTop / "torsions.top");
  EXPECT_EQ(s.exclusions[0], (std::vector<int>{1, 2, 3, 5, 6}));  // 1-2, 1-3 (two), 1-4 (two); not 1-5
  EXPECT_EQ(s.exclusions[4], (std::vector<int>{1, 2, 3, 5}));
  EXPECT_EQ(s.exclusions[7], (std::vector<int>{8, 9, 10, 12, 13}));
  expect_exclusions_consistent(s);
}

TEST(Topology, BondsBecomeConstraintsAsGromppsConstraintsOption) {
  const System none = read_topology(kTop / "torsions.top");
  EXPECT_EQ(none.bonds.size(), 12u);
  EXPECT_TRUE(none.constraints.empty());
  EXPECT_EQ(none.bonds_constrained, 0);
  // Hydrogens by name: H1, H2, H3 (bonds 1-2, 3-6, 2-7 of each molecule).
  const System h = read_topology(kTop / "torsions.top", BondConstraints::h_bonds);
  EXPECT_EQ(h.bonds.size(), 6u);
  ASSERT_EQ(h.constraints.size(), 6u);
  EXPECT_EQ(h.bonds_constrained, 6);
  EXPECT_EQ(std::tie(h.constraints[0].i, h.constraints[0].j), std::make_tuple(0, 1));
  EXPECT_DOUBLE_EQ(h.constraints[0].length, 0.109);
  EXPECT_EQ(std::tie(h.constraints[1].i, h.constraints[1].j), std::make_tuple(2, 5));
  for (const Bond& b : h.bonds) EXPECT_FALSE(hydrogen_like(h.atom_names[b.i]) || hydrogen_like(h.atom_names[b.j]));
  EXPECT_EQ(h.exclusions, none.exclusions);  // constrained bonds are still chemical bonds
  EXPECT_EQ(h.degrees_of_freedom(), none.degrees_of_freedom() - 6);
  const System all = read_topology(kTop / "torsions.top", BondConstraints::all_bonds);
  EXPECT_TRUE(all.bonds.empty());
  EXPECT_EQ(all.constraints.size(), 12u);
  EXPECT_EQ(all.bonds_constrained, 12);
  EXPECT_DOUBLE_EQ(all.constraints[3].length, 0.140);
}
