// digilap-spectrum --labels: the spectra of every structure of a segmentation in one run, in the
// layout ShapeDNA and BrainPrint users read (one column per structure; rows area, volume,
// ev0 ... ev<count-1>), a failing structure a column of NaN with its reason in the log.
#pragma once

#include "../common/app_common.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace digilap::app {

/// How the eigenvalues of a structure are scaled (BrainPrint's options): none; surface:
/// lambda * area; volume: lambda * volume^(2/3) (both make them unit-free).
enum class Normalization { None, Surface, Volume };

struct LabelBatchOptions {
  std::string labels = "all";   ///< "all", or a list of labels and ranges: "3,5,10-12"
  std::string names;            ///< a table of names (see read_label_names), or "" for label_N
  Normalization normalize = Normalization::None;
  bool reweight = false;        ///< lambda_i / i for i >= 1 (ev0 stays)
  int count = 50;               ///< eigenvalues per structure
  /// The eigen-solver's (SpectrumOptions::tolerance): the batch writes eigenvalues alone.
  double tolerance = kEigenvaluesOnlyTolerance;
  bool matrix_free = false;     ///< products (surface::MatrixFreeSurfaceOperator) instead of the assembled operator
};

/// "all" (every label of the volume) or a list of labels and ranges, ascending and unique.
/// Throws digilap::Error for a list that does not parse or a negative label.
std::vector<std::int64_t> parse_label_list(const std::string& text, const std::vector<std::int64_t>& present);

/// Label names from a text table: one structure a line, `index name ...` (atlases' tables,
/// tab or space separated) or FreeSurfer's colour LUT `index name R G B A`; '#' comments and
/// blank lines skipped. Lines that do not start with an integer and a name are counted in
/// `unparsed` (the caller warns) and skipped. Throws digilap::Error when the file cannot be read.
std::map<std::int64_t, std::string> read_label_names(const std::string& path, std::size_t* unparsed = nullptr);

/// Runs the batch over a volume (front-end options as for one structure: --largest,
/// --min-size, --kR, ...) and writes spectra.csv (Laplace-Beltrami estimates), spectra_raw.csv
/// (the operator's eigenvalues) and spectra_log.csv into out_dir. Returns the number of
/// structures that failed.
int run_label_batch(const FrontEndOptions& front_end, const HeatLaplacianOptions& op_options,
                    const LabelBatchOptions& batch, const std::string& out_dir, Progress& progress);

}  // namespace digilap::app
