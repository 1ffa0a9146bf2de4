#include "label_batch.hpp"

#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/matrix_free.hpp"
#include "digilap/surface/volume.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace digilap::app {

namespace {

// One structure's result: its eigenvalues (raw and estimates, NaN past what it has), area,
// volume, and what happened.
struct StructureResult {
  std::int64_t label = 0;
  std::string name, status = "ok", reason;
  Eigen::VectorXd raw, estimates;
  double area = std::nan(""), volume = std::nan(""), t = std::nan("");
  std::size_t surfaces = 0, surfels = 0, zero_area = 0;
  double seconds = 0;
};

std::string csv_field(const std::string& text) {  // quoted when it holds a comma or a quote
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

StructureResult run_structure(std::int64_t label, const std::string& name, surface::VoxelSet voxels, const FrontEndOptions& fe,
                              const HeatLaplacianOptions& op_options, const LabelBatchOptions& batch, Progress& quiet) {
  StructureResult r;
  r.label = label, r.name = name;
  r.raw = r.estimates = Eigen::VectorXd::Constant(batch.count, std::nan(""));
  const auto start = std::chrono::steady_clock::now();
  try {
    if (label == 0) throw Error("label 0 is the background");
    if (voxels.empty()) throw Error("no voxel has the label " + std::to_string(label));
    const SurfaceFrontEnd sfe = surface_front_end(std::move(voxels), name, fe, quiet);
    r.surfaces = sfe.surfels.surfaces();
    r.surfels = sfe.surfels.size();
    r.zero_area = sfe.measures.clamped;
    r.area = sfe.measures.total_area();
    r.volume = surface::enclosed_volume(sfe.surfels);
    SpectrumOptions so;
    so.memory_limit_bytes = op_options.memory_limit_bytes;
    so.tolerance = batch.tolerance;
    const Eigen::Index support = static_cast<Eigen::Index>(sfe.surfels.size()) - static_cast<Eigen::Index>(sfe.measures.clamped);
    so.count = static_cast<int>(std::min<Eigen::Index>(batch.count, support - 1));
    if (so.count < batch.count) {
      r.status = "partial";
      r.reason = std::to_string(support) + " surfels with area give " + std::to_string(so.count) + " eigenpairs, not " +
                 std::to_string(batch.count);
    }
    if (so.count < 1) throw Error("too few surfels with area (" + std::to_string(support) + ") for a spectrum");
    Spectrum s;
    if (!batch.matrix_free) {
      const surface::SurfaceOperator op = surface::heat_laplacian(sfe.surfels, sfe.measures, op_options);
      r.t = op.t;
      s = smallest_eigenpairs(op, so);
    } else {  // products in O(N) memory (--matrix-free): for large structures
      const surface::MatrixFreeSurfaceOperator op(sfe.surfels, sfe.measures, op_options);
      r.t = op.t();
      s = smallest_eigenpairs(op, so);
    }
    r.raw.head(s.eigenvalues.size()) = s.eigenvalues;
    r.estimates.head(s.laplace_beltrami.size()) = s.laplace_beltrami;
  } catch (const std::exception& e) {
    r.status = "failed";
    r.reason = e.what();
    r.raw.setConstant(std::nan(""));
    r.estimates.setConstant(std::nan(""));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

// BrainPrint's normalizations and reweighting, applied to one column of eigenvalues.
Eigen::VectorXd scaled(Eigen::VectorXd ev, const StructureResult& r, const LabelBatchOptions& batch) {
  if (batch.normalize == Normalization::Surface) ev *= r.area;
  if (batch.normalize == Normalization::Volume) ev *= std::cbrt(r.volume * r.volume);
  if (batch.reweight)
    for (Eigen::Index i = 1; i < ev.size(); ++i) ev[i] /= static_cast<double>(i);
  return ev;
}

void write_table(const std::string& path, const std::vector<StructureResult>& results, bool raw, const LabelBatchOptions& batch) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write '" + path + "'");
  out.precision(12);
  out << "structure";
  for (const auto& r : results) out << ',' << csv_field(r.name);
  out << "\nlabel";
  for (const auto& r : results) out << ',' << r.label;
  out << "\narea";
  for (const auto& r : results) out << ',' << r.area;
  out << "\nvolume";
  for (const auto& r : results) out << ',' << r.volume;
  out << '\n';
  std::vector<Eigen::VectorXd> columns;
  for (const auto& r : results) columns.push_back(scaled(raw ? r.raw : r.estimates, r, batch));
  for (int k = 0; k < batch.count; ++k) {
    out << "ev" << k;
    for (const auto& c : columns) out << ',' << c[k];
    out << '\n';
  }
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

void write_log(const std::string& path, const std::vector<StructureResult>& results) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write '" + path + "'");
  out.precision(8);
  out << "label,structure,status,surfaces,surfels,zero_area,area,volume,t,seconds,reason\n";
  for (const auto& r : results)
    out << r.label << ',' << csv_field(r.name) << ',' << r.status << ',' << r.surfaces << ',' << r.surfels << ',' << r.zero_area
        << ',' << r.area << ',' << r.volume << ',' << r.t << ',' << r.seconds << ',' << csv_field(r.reason) << '\n';
}

}  // namespace

std::vector<std::int64_t> parse_label_list(const std::string& text, const std::vector<std::int64_t>& present) {
  if (text == "all") return present;
  std::vector<std::int64_t> labels;
  std::stringstream items(text);
  std::string item;
  auto number = [&](const std::string& s) -> std::int64_t {
    std::size_t used = 0;
    long long v = 0;
    try {
      v = std::stoll(s, &used);
    } catch (...) {
      used = 0;
    }
    if (used == 0 || used != s.size()) throw Error("--labels: '" + s + "' is not a label (give all, or labels and ranges: 3,5,10-12)");
    if (v < 0) throw Error("--labels: labels are >= 0, got " + s);
    return v;
  };
  while (std::getline(items, item, ',')) {
    if (item.empty()) continue;
    const std::size_t dash = item.find('-', 1);
    if (dash == std::string::npos) {
      labels.push_back(number(item));
      continue;
    }
    const std::int64_t a = number(item.substr(0, dash)), b = number(item.substr(dash + 1));
    if (b < a || b - a > 100000) throw Error("--labels: the range '" + item + "' is empty or too long");
    for (std::int64_t l = a; l <= b; ++l) labels.push_back(l);
  }
  if (labels.empty()) throw Error("--labels: no label in '" + text + "'");
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  return labels;
}

std::map<std::int64_t, std::string> read_label_names(const std::string& path, std::size_t* unparsed) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read the table of names '" + path + "' (does it exist?)");
  std::map<std::int64_t, std::string> names;
  std::size_t bad = 0;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    long long index = 0;
    std::string name;
    if (!(fields >> index >> name) || index < 0) {
      ++bad;
      continue;
    }
    names[index] = name;
  }
  if (unparsed) *unparsed = bad;
  return names;
}

int run_label_batch(const FrontEndOptions& fe, const HeatLaplacianOptions& op_options, const LabelBatchOptions& batch,
                    const std::string& out_dir, Progress& progress) {
  if (batch.count < 1) throw Error("--count must be >= 1 for a batch of labels");
  progress.start("read labels");
  surface::VolumeOptions vo;
  vo.h = fe.h;
  std::vector<surface::LabelVoxels> structures = surface::read_labels(fe.volume, vo);
  progress.finish();
  std::vector<std::int64_t> present;
  for (const auto& s : structures) present.push_back(s.label);
  const std::vector<std::int64_t> labels = parse_label_list(batch.labels, present);
  std::map<std::int64_t, std::string> names;
  if (!batch.names.empty()) {
    std::size_t unparsed = 0;
    names = read_label_names(batch.names, &unparsed);
    if (unparsed > 0 && !progress.quiet())
      std::fprintf(stderr, "warning: %zu line(s) of '%s' are not 'index name ...': skipped\n", unparsed, batch.names.c_str());
  }
  // Structures in parallel, largest first (one thread each: small operators gain little from
  // two threads, and two structures at once keep both cores busy); each one's result does not
  // depend on the number of threads.
  std::vector<surface::VoxelSet> voxels(labels.size());
  std::vector<std::int64_t> work(labels.size());
  for (std::size_t n = 0; n < labels.size(); ++n) {
    const auto found = std::find_if(structures.begin(), structures.end(), [&](const auto& s) { return s.label == labels[n]; });
    if (found != structures.end()) voxels[n] = std::move(found->voxels);
    work[n] = voxels[n].empty() ? 0 : static_cast<std::int64_t>(voxels[n].memory_bytes());
  }
  std::vector<std::size_t> order(labels.size());
  for (std::size_t n = 0; n < order.size(); ++n) order[n] = n;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return work[a] > work[b]; });
  std::vector<StructureResult> results(labels.size());
  std::size_t done = 0;
  const auto count = static_cast<std::ptrdiff_t>(order.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t q = 0; q < count; ++q) {
    const std::size_t n = order[static_cast<std::size_t>(q)];
    const std::int64_t label = labels[n];
    const auto name = names.count(label) ? names.at(label) : "label_" + std::to_string(label);
    // This thread's own regions (nested: serial) and Eigen's blocking sized for one thread, as in
    // a run of one structure on one thread: the same bits as that run, whatever the threads.
    omp_set_num_threads(1);
    Progress quiet(true);  // the structures' own stages stay silent: one bar over the labels
    results[n] = run_structure(label, name, std::move(voxels[n]), fe, op_options, batch, quiet);
#pragma omp critical(label_batch_progress)
    progress.bar("labels", static_cast<double>(++done) / static_cast<double>(labels.size()));
  }
  progress.end_bar();
  std::filesystem::create_directories(out_dir);
  write_table(out_dir + "/spectra.csv", results, false, batch);
  write_table(out_dir + "/spectra_raw.csv", results, true, batch);
  write_log(out_dir + "/spectra_log.csv", results);
  int failed = 0;
  std::printf("# %s: %zu structure(s), %d eigenvalues each (Laplace-Beltrami estimates%s%s)\n", fe.volume.c_str(), results.size(),
              batch.count,
              batch.normalize == Normalization::Surface ? ", times the area" : batch.normalize == Normalization::Volume ? ", times volume^(2/3)" : "",
              batch.reweight ? ", reweighted by 1/i" : "");
  std::printf("| label | structure | status | surfaces | surfels | zero area | area | volume | ev1 | ev%d | seconds |\n", batch.count - 1);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : results) {
    failed += r.status == "failed";
    const Eigen::VectorXd ev = scaled(r.estimates, r, batch);
    std::printf("| %lld | %s | %s | %zu | %zu | %zu | %.6g | %.6g | %.6g | %.6g | %.2f |\n", static_cast<long long>(r.label),
                r.name.c_str(), r.status == "failed" ? ("failed: " + r.reason).c_str() : r.status.c_str(), r.surfaces, r.surfels,
                r.zero_area, r.area, r.volume, batch.count > 1 ? ev[1] : std::nan(""), ev[batch.count - 1], r.seconds);
  }
  std::printf("\nwrote %s/spectra.csv\nwrote %s/spectra_raw.csv\nwrote %s/spectra_log.csv\n", out_dir.c_str(), out_dir.c_str(),
              out_dir.c_str());
  return failed;
}

}  // namespace digilap::app
