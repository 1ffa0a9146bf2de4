// The smallest eigenpairs of -A x = lambda M x across ranks with SLEPc (surface_operator.hpp).
// Zero-area surfels have zero rows and columns in A = M L and a zero mass: they are taken out
// (MatCreateSubMatrix on the others) so that M is positive definite, as EPS_GHEP needs, and put
// back afterwards as the kernel-weighted mean of their neighbours ((L x)_i = 0). Each surface's
// constant vector is an exact eigenvector of 0: it is given, and deflated from the search.
#include "digilap/core/error.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/mpi/surface_operator.hpp"

#include "collectives.hpp"

#include <slepceps.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace digilap::mpi {

using detail::all_reduce;
using detail::petsc_check;
using detail::Ranks;

DistributedEigenSolver distributed_eigen_solver_by_name(const std::string& name) {
  if (name == "lobpcg") return DistributedEigenSolver::Lobpcg;
  if (name == "lobpcg-amg") return DistributedEigenSolver::LobpcgAmg;
  if (name == "krylov-schur") return DistributedEigenSolver::KrylovSchur;
  if (name == "shift-invert") return DistributedEigenSolver::KrylovSchurInvert;
  throw Error("unknown eigen-solver '" + name + "' (krylov-schur, lobpcg, lobpcg-amg or shift-invert)");
}

namespace {
const char* solver_name(DistributedEigenSolver s) {
  switch (s) {
    case DistributedEigenSolver::Lobpcg: return "lobpcg";
    case DistributedEigenSolver::LobpcgAmg: return "lobpcg-amg";
    case DistributedEigenSolver::KrylovSchur: return "krylov-schur";
    default: return "shift-invert";
  }
}

// PETSc objects freed on every path out.
struct Owned {
  std::vector<Mat> mats;
  std::vector<Vec> vecs;
  IS is = nullptr;
  EPS eps = nullptr;
  ~Owned() {
    for (Mat& m : mats) MatDestroy(&m);
    for (Vec& v : vecs) VecDestroy(&v);
    if (is) ISDestroy(&is);
    if (eps) EPSDestroy(&eps);
  }
};

// One PETSc option set for a scope and taken out after it (a null name sets nothing).
class ScopedOption {
 public:
  ScopedOption(const char* name, const std::string& value) : name_(name) {
    if (name_) petsc_check(PetscOptionsSetValue(nullptr, name_, value.c_str()), "PetscOptionsSetValue");
  }
  ~ScopedOption() {
    if (name_) PetscOptionsClearValue(nullptr, name_);
  }
  ScopedOption(const ScopedOption&) = delete;
  ScopedOption& operator=(const ScopedOption&) = delete;

 private:
  const char* name_;
};

// SLEPc's monitor hook: the caller's progress function (ctx) with the iteration and converged count.
PetscErrorCode report_progress(EPS, PetscInt iteration, PetscInt converged, PetscScalar*, PetscScalar*, PetscReal*, PetscInt, void* ctx) {
  (*static_cast<std::function<void(int, int)>*>(ctx))(static_cast<int>(iteration), static_cast<int>(converged));
  return 0;
}

// INFOG(1) of the MUMPS factor behind a Cholesky PC, 0 when there is none yet.
PetscInt mumps_status(PC pc) {
  Mat factor = nullptr;
  PetscInt status = 0;
  if (PCFactorGetMatrix(pc, &factor) != 0 || !factor) return 0;
  if (MatMumpsGetInfog(factor, 1, &status) != 0) return 0;
  return status;
}
}  // namespace

DistributedSpectrum distributed_smallest_eigenpairs(const DistributedSurfaceOperator& op, int count, DistributedEigenSolver solver,
                                                    double tolerance, const std::function<void(int, int)>& progress) {
  if (count < 1) throw Error("distributed_smallest_eigenpairs: count must be at least 1, got " + std::to_string(count));
  require_positive("distributed_smallest_eigenpairs: tolerance", tolerance);
  const Ranks ranks(op.comm);
  const auto n_local = static_cast<PetscInt>(op.row_end - op.row_begin);
  const std::size_t surfaces = op.surface_t.size();
  // Each surface's area; the massive rows.
  std::vector<double> area(surfaces, 0.0);
  std::vector<PetscInt> massive;
  for (PetscInt q = 0; q < n_local; ++q) {
    area[static_cast<std::size_t>(op.surface_of[static_cast<std::size_t>(q)])] += op.mu[q];
    if (op.mu[q] > 0) massive.push_back(static_cast<PetscInt>(op.row_begin) + q);
  }
  all_reduce(ranks, area, MPI_SUM);
  const double total_area = std::accumulate(area.begin(), area.end(), 0.0);
  std::vector<std::size_t> with_area;  // the surfaces with a zero eigenvalue
  for (std::size_t c = 0; c < surfaces; ++c)
    if (area[c] > 0) with_area.push_back(c);
  const std::int64_t massive_total = all_reduce(ranks, static_cast<std::int64_t>(massive.size()), MPI_SUM);
  // The submatrix numbers the massive rows 0, 1, ... across the ranks in order.
  std::int64_t sub_begin = 0, massive_here = static_cast<std::int64_t>(massive.size());
  MPI_Exscan(&massive_here, &sub_begin, 1, MPI_INT64_T, MPI_SUM, op.comm);
  if (ranks.rank == 0) sub_begin = 0;
  const int zeros = static_cast<int>(std::min<std::size_t>(with_area.size(), static_cast<std::size_t>(count)));
  const int wanted = std::min<int>(count - zeros, static_cast<int>(massive_total) - static_cast<int>(with_area.size()));

  DistributedSpectrum out;
  out.solver = solver_name(solver);
  out.tolerance = tolerance;
  out.eigenvalues.resize(zeros + std::max(wanted, 0));
  out.eigenvectors.setZero(n_local, out.eigenvalues.size());
  // The zero eigenpairs: each surface's constant, M-normalized.
  for (int z = 0; z < zeros; ++z) {
    out.eigenvalues[z] = 0;
    for (PetscInt q = 0; q < n_local; ++q)
      if (static_cast<std::size_t>(op.surface_of[static_cast<std::size_t>(q)]) == with_area[static_cast<std::size_t>(z)])
        out.eigenvectors(q, z) = 1 / std::sqrt(area[with_area[static_cast<std::size_t>(z)]]);
  }
  if (wanted > 0) {
    Owned own;
    petsc_check(ISCreateGeneral(op.comm, static_cast<PetscInt>(massive.size()), massive.data(), PETSC_COPY_VALUES, &own.is), "ISCreateGeneral");
    Mat stiffness = nullptr, mass = nullptr;
    petsc_check(MatCreateSubMatrix(op.A, own.is, own.is, MAT_INITIAL_MATRIX, &stiffness), "MatCreateSubMatrix");
    own.mats.push_back(stiffness);
    petsc_check(MatScale(stiffness, -1.0), "MatScale");  // -A: positive semidefinite
    petsc_check(MatSetOption(stiffness, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
    const auto n_massive = static_cast<PetscInt>(massive.size());
    petsc_check(MatCreateAIJ(op.comm, n_massive, n_massive, static_cast<PetscInt>(massive_total), static_cast<PetscInt>(massive_total), 1,
                             nullptr, 0, nullptr, &mass), "MatCreateAIJ");
    own.mats.push_back(mass);
    for (PetscInt q = 0, at = 0; q < n_local; ++q)
      if (op.mu[q] > 0) {
        const auto g = static_cast<PetscInt>(sub_begin + at++);
        petsc_check(MatSetValue(mass, g, g, op.mu[q], INSERT_VALUES), "MatSetValue");
      }
    petsc_check(MatAssemblyBegin(mass, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    petsc_check(MatAssemblyEnd(mass, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
    // Krylov-Schur on products only solves the standard problem M^(-1/2) (-A) M^(-1/2) y = lambda y
    // (x = M^(-1/2) y), as the one-machine Lanczos does: M is diagonal, so the scaling is exact
    // and done in place on the copy of A; the spectrum is bounded by about 1/t, so the smallest
    // eigenvalues come out of plain Krylov iterations without a factorization.
    const bool standard = solver == DistributedEigenSolver::KrylovSchur;
    Vec inverse_root_mass = nullptr;
    if (standard) {
      petsc_check(MatCreateVecs(stiffness, &inverse_root_mass, nullptr), "MatCreateVecs");
      own.vecs.push_back(inverse_root_mass);
      petsc_check(MatGetDiagonal(mass, inverse_root_mass), "MatGetDiagonal");
      petsc_check(VecSqrtAbs(inverse_root_mass), "VecSqrtAbs");
      petsc_check(VecReciprocal(inverse_root_mass), "VecReciprocal");
      petsc_check(MatDiagonalScale(stiffness, inverse_root_mass, inverse_root_mass), "MatDiagonalScale");
    }
    // The constants of the surfaces (M^(1/2) 1 for the standard problem), deflated.
    std::vector<Vec> constants;
    for (std::size_t c : with_area) {
      Vec v;
      petsc_check(MatCreateVecs(stiffness, &v, nullptr), "MatCreateVecs");
      own.vecs.push_back(v);
      for (PetscInt q = 0, at = 0; q < n_local; ++q)
        if (op.mu[q] > 0) {
          const auto g = static_cast<PetscInt>(sub_begin + at++);
          if (static_cast<std::size_t>(op.surface_of[static_cast<std::size_t>(q)]) == c)
            petsc_check(VecSetValue(v, g, (standard ? std::sqrt(op.mu[q]) : 1.0) / std::sqrt(area[c]), INSERT_VALUES), "VecSetValue");
        }
      petsc_check(VecAssemblyBegin(v), "VecAssemblyBegin");
      petsc_check(VecAssemblyEnd(v), "VecAssemblyEnd");
      constants.push_back(v);
    }
    // A shift near the first nonzero eigenvalue of a sphere of the same area (8 pi / area).
    const double sigma = 8 * M_PI / total_area;
    Mat shifted = nullptr;  // -A + sigma M: definite, so that AMG has no null space to fight
    if (solver == DistributedEigenSolver::LobpcgAmg) {
      petsc_check(MatDuplicate(stiffness, MAT_COPY_VALUES, &shifted), "MatDuplicate");
      own.mats.push_back(shifted);
      petsc_check(MatAXPY(shifted, sigma, mass, SUBSET_NONZERO_PATTERN), "MatAXPY");
    }
    // MUMPS sizes its workspace from the symbolic analysis plus ICNTL(14) percent. Its LDL^T
    // pivoting and its dynamic scheduling of the tree among ranks can need more than that, and
    // then it fails with INFOG(1) = -8 or -9 (seen on a loaded 2-core machine, 3 ranks). The
    // answer MUMPS documents is a larger ICNTL(14): we start at 50 and retry at 200 and 800
    // (checked by starting at 0: 3 ranks failed with -9 once, then passed at 200).
    // Krylov-Schur from one start vector finds the second copy of a repeated eigenvalue late (a
    // surface's symmetry, or two surfaces of one shape): asked for exactly `wanted`, it stopped
    // with a copy missing (the 5-surface test volume). Guard eigenpairs past the wanted ones give
    // the copies time to converge; only the `wanted` smallest are kept.
    const int guard = solver == DistributedEigenSolver::KrylovSchur ? std::max(5, wanted / 2) : 0;
    const int asked = std::min<int>(wanted + guard, static_cast<int>(massive_total) - static_cast<int>(with_area.size()));
    PetscBool user_relaxation = PETSC_FALSE;
    petsc_check(PetscOptionsHasName(nullptr, nullptr, "-st_mat_mumps_icntl_14", &user_relaxation), "PetscOptionsHasName");
    const int relaxations[] = {50, 200, 800};
    const int attempts = solver == DistributedEigenSolver::KrylovSchurInvert && !user_relaxation ? 3 : 1;
    for (int attempt = 0;; ++attempt) {
      const int relaxation = relaxations[attempt];
      if (own.eps) EPSDestroy(&own.eps);
      petsc_check(EPSCreate(op.comm, &own.eps), "EPSCreate");
      EPS eps = own.eps;
      petsc_check(EPSSetOperators(eps, stiffness, standard ? nullptr : mass), "EPSSetOperators");
      petsc_check(EPSSetProblemType(eps, standard ? EPS_HEP : EPS_GHEP), "EPSSetProblemType");
      petsc_check(EPSSetDimensions(eps, asked, PETSC_DEFAULT, PETSC_DEFAULT), "EPSSetDimensions");
      petsc_check(EPSSetTolerances(eps, tolerance, 10000), "EPSSetTolerances");
      petsc_check(EPSSetDeflationSpace(eps, static_cast<PetscInt>(constants.size()), constants.data()), "EPSSetDeflationSpace");
      ST st;
      KSP ksp;
      PC pc;
      petsc_check(EPSGetST(eps, &st), "EPSGetST");
      petsc_check(STGetKSP(st, &ksp), "STGetKSP");
      petsc_check(KSPGetPC(ksp, &pc), "KSPGetPC");
      petsc_check(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
      if (standard) {  // products only: no ST, no KSP
        petsc_check(EPSSetType(eps, EPSKRYLOVSCHUR), "EPSSetType");
        petsc_check(EPSSetWhichEigenpairs(eps, EPS_SMALLEST_REAL), "EPSSetWhichEigenpairs");
      } else if (solver == DistributedEigenSolver::KrylovSchurInvert) {
        petsc_check(EPSSetType(eps, EPSKRYLOVSCHUR), "EPSSetType");
        petsc_check(EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE), "EPSSetWhichEigenpairs");
        petsc_check(EPSSetTarget(eps, -sigma), "EPSSetTarget");  // -A + sigma M is positive definite
        petsc_check(STSetType(st, STSINVERT), "STSetType");
        petsc_check(PCSetType(pc, PCCHOLESKY), "PCSetType");
        petsc_check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
      } else {
        petsc_check(EPSSetType(eps, EPSLOBPCG), "EPSSetType");
        petsc_check(EPSSetWhichEigenpairs(eps, EPS_SMALLEST_REAL), "EPSSetWhichEigenpairs");
        petsc_check(STSetType(st, STPRECOND), "STSetType");
        if (solver == DistributedEigenSolver::LobpcgAmg) {
          petsc_check(STSetPreconditionerMat(st, shifted), "STSetPreconditionerMat");
          petsc_check(PCSetType(pc, PCHYPRE), "PCSetType");
          petsc_check(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType");
        } else {
          petsc_check(PCSetType(pc, PCJACOBI), "PCSetType");
        }
      }
      petsc_check(EPSSetFromOptions(eps), "EPSSetFromOptions");  // -eps_* / -st_* options still apply
      if (progress)
        petsc_check(EPSMonitorSet(eps, report_progress, const_cast<std::function<void(int, int)>*>(&progress), nullptr), "EPSMonitorSet");
      const bool retry_possible = attempt + 1 < attempts;
      PetscErrorCode code = 0;
      {
        // The factor reads ICNTL(14) from the options when it is set up, inside EPSSolve.
        const ScopedOption relax(attempts > 1 ? "-st_mat_mumps_icntl_14" : nullptr, std::to_string(relaxation));
        if (retry_possible) PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);  // a retried failure prints nothing
        code = EPSSolve(eps);
        if (retry_possible) PetscPopErrorHandler();
      }
      if (code == 0) break;
      const PetscInt status = solver == DistributedEigenSolver::KrylovSchurInvert ? mumps_status(pc) : 0;
      const bool out_of_workspace = status == -8 || status == -9;
      if (out_of_workspace && retry_possible) continue;
      if (out_of_workspace)
        throw Error("distributed_smallest_eigenpairs: MUMPS ran out of workspace (INFOG(1) = " + std::to_string(status) +
                    ") even with ICNTL(14) = " + std::to_string(relaxation) + "; try another --solver or -st_mat_mumps_icntl_14 <percent>");
      if (status < 0)
        throw Error("distributed_smallest_eigenpairs: the MUMPS factorization failed with INFOG(1) = " + std::to_string(status) +
                    " (see the MUMPS user guide); try another --solver");
      petsc_check(code, "EPSSolve");
    }
    EPS eps = own.eps;
    PetscInt converged = 0, iterations = 0;
    petsc_check(EPSGetConverged(eps, &converged), "EPSGetConverged");
    petsc_check(EPSGetIterationNumber(eps, &iterations), "EPSGetIterationNumber");
    out.iterations = static_cast<int>(iterations);
    if (converged < wanted)
      throw Error("distributed_smallest_eigenpairs: SLEPc (" + std::string(out.solver) + ") converged " + std::to_string(converged) + " of " +
                  std::to_string(wanted) + " eigenpairs in " + std::to_string(iterations) + " iterations; try another --solver");
    // Back to every surfel: massive entries from x, zero-area ones from (L x)_i / (-L_ii).
    Vec x, full, lx, diagonal;
    petsc_check(MatCreateVecs(stiffness, &x, nullptr), "MatCreateVecs");
    own.vecs.push_back(x);
    petsc_check(MatCreateVecs(op.L, &full, &lx), "MatCreateVecs");
    own.vecs.push_back(full), own.vecs.push_back(lx);
    petsc_check(MatCreateVecs(op.L, &diagonal, nullptr), "MatCreateVecs");
    own.vecs.push_back(diagonal);
    petsc_check(MatGetDiagonal(op.L, diagonal), "MatGetDiagonal");
    for (int k = 0; k < wanted; ++k) {
      PetscScalar value;
      petsc_check(EPSGetEigenpair(eps, k, &value, nullptr, x, nullptr), "EPSGetEigenpair");
      if (standard) petsc_check(VecPointwiseMult(x, x, inverse_root_mass), "VecPointwiseMult");  // x = M^(-1/2) y
      out.eigenvalues[zeros + k] = value;
      petsc_check(VecSet(full, 0.0), "VecSet");
      petsc_check(VecISCopy(full, own.is, SCATTER_FORWARD, x), "VecISCopy");
      petsc_check(MatMult(op.L, full, lx), "MatMult");
      const PetscScalar *f, *l, *d;
      petsc_check(VecGetArrayRead(full, &f), "VecGetArrayRead");
      petsc_check(VecGetArrayRead(lx, &l), "VecGetArrayRead");
      petsc_check(VecGetArrayRead(diagonal, &d), "VecGetArrayRead");
      for (PetscInt q = 0; q < n_local; ++q)
        out.eigenvectors(q, zeros + k) = op.mu[q] > 0 ? f[q] : (d[q] != 0 ? l[q] / -d[q] : 0.0);
      VecRestoreArrayRead(full, &f), VecRestoreArrayRead(lx, &l), VecRestoreArrayRead(diagonal, &d);
    }
  }
  // Laplace-Beltrami estimates with the heat time of the surface holding each eigenvector.
  out.laplace_beltrami.resize(out.eigenvalues.size());
  for (Eigen::Index k = 0; k < out.eigenvalues.size(); ++k) {
    std::vector<double> weight(surfaces, 0.0);
    for (PetscInt q = 0; q < n_local; ++q)
      weight[static_cast<std::size_t>(op.surface_of[static_cast<std::size_t>(q)])] += op.mu[q] * out.eigenvectors(q, k) * out.eigenvectors(q, k);
    all_reduce(ranks, weight, MPI_SUM);
    const auto c = static_cast<std::size_t>(std::max_element(weight.begin(), weight.end()) - weight.begin());
    out.laplace_beltrami[k] = laplace_beltrami_eigenvalues(out.eigenvalues.segment(k, 1), op.surface_t[c], nullptr, KernelCut{2, op.k})[0];
  }
  return out;
}

}  // namespace digilap::mpi
