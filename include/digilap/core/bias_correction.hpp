// digilap — pointwise Laplace–Beltrami estimates with the heat kernel's O(t) bias removed (core,
// any dimension).
//
// The heat-kernel Laplacian approximates (e^(tΔ) − I) / t = Δ + (t/2) Δ² + O(t²) (SPEC §4), so
// L g carries the bias (t/2) Δ² g. With t ∝ h^(2/3) that bias decays as h^(2/3) and ends up
// dominating the pointwise error (the unit sphere's x², docs/accuracy.md). The spectra remove
// it exactly with −ln(1 − λt)/t; a pointwise estimate removes its first order with
//
//     L_c g = L g − (t/2) L S L g,   S = I + t L,
//
// the start of the series ln(I + tL)/t = L − (t/2) L² + …, with one heat step S (an average over
// about sqrt(t)) before the second product. Without S, that product amplifies the discretization
// noise of L g, which lives at the kernel's own scale (x² on the unit sphere at h = 0.025: 3.72%
// with L − (t/2) L², 2.42% with L_c, 4.34% for L). On an eigenvector of −L with eigenvalue λ,
// L_c multiplies by −λ (1 + tλ/2 − t²λ²/2): closer to −ln(1 − tλ)/t = −λ (1 + tλ/2 + O(t²λ²)),
// and still ≤ 0 for tλ ≤ 2, the whole of the kernel operator's spectrum (its rows' Gershgorin
// bound). L_c is a polynomial in L: its rows sum to 0 and it is self-adjoint for the M-inner
// product, like L. It costs three products of L.
#pragma once

#include "digilap/core/operator.hpp"

#include <Eigen/Core>

#include <functional>

namespace digilap {

/// y = L x for a block x (N x b), of any operator: assembled, matrix-free, distributed.
using LaplacianProduct = std::function<void(const Eigen::MatrixXd& x, Eigen::MatrixXd& y)>;

/// L_c g = L g − (T/2) L (I + T L) L g for the columns of g, T = diag(t_of_row): each row's heat
/// time, its part's t (the parts do not interact, so this is L_c on each part). With `plain`,
/// also L g, the first of the three products. Throws digilap::Error for sizes that do not match
/// or a t that is negative or not finite.
Eigen::MatrixXd bias_corrected_laplacian(const LaplacianProduct& apply_l, const Eigen::VectorXd& t_of_row, const Eigen::MatrixXd& g,
                                         Eigen::MatrixXd* plain = nullptr);

/// L_c g on an assembled operator, each part with its own t (HeatOperator::time_of_part).
Eigen::MatrixXd bias_corrected_laplacian(const HeatOperator& op, const Eigen::MatrixXd& g, Eigen::MatrixXd* plain = nullptr);

/// Each row's heat time: part p's t on rows [row_offset[p], row_offset[p + 1]).
Eigen::VectorXd heat_time_of_rows(const std::vector<Eigen::Index>& row_offset, const std::vector<double>& part_t);

}  // namespace digilap
