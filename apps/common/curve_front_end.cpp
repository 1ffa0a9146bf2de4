#include "curve_front_end.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace digilap::app {

FrontEnd run_front_end(const FrontEndOptions& o, Progress& progress) {
  FrontEnd fe;
  ContourFilter filter;
  if (o.image.empty()) {
    fe.shape = make_shape(o.shape);
    if (!std::isfinite(o.rotate_degrees)) throw Error("--rotate must be a finite angle in degrees");
    if (o.rotate_degrees != 0 || !o.centre.empty())
      fe.shape->set_pose(o.centre.empty() ? Eigen::Vector2d::Zero() : Eigen::Vector2d(o.centre[0], o.centre[1]),
                         o.rotate_degrees * kPi / 180);
    fe.name = fe.shape->name();
    fe.exact_length = fe.shape->length();
    const double h = o.h == 0 ? 0.01 : o.h;
    progress.start("digitize");
    fe.set = digitize(*fe.shape, h);
    fe.seconds_digitize = progress.finish();
    if (fe.set.empty()) throw Error("the digitization at h = " + std::to_string(h) + " is empty: use a smaller h");
  } else {
    if (o.normals == "exact") throw Error("--normals exact needs a reference shape: an image has no exact curve");
    fe.name = std::filesystem::path(o.image).filename().string();
    fe.exact_length = std::nan("");
    progress.start("read image");
    const GrayImage image = read_image(o.image);
    fe.set = binarize(image, BinarizeOptions{o.h, o.threshold, o.invert});
    fe.seconds_digitize = progress.finish();
    if (fe.set.empty())
      throw Error(o.image + ": no foreground pixel (all values are " + (o.invert ? "below" : "at or above") +
                  " the threshold); try --invert or another --threshold");
    filter.min_linels = o.min_linels;
    filter.largest_only = o.largest;
  }
  progress.start("contours");
  FilteredContours kept = filter_contours(track_contours(fe.set), filter);
  fe.contours = std::move(kept.contours);
  fe.seconds_contours = progress.finish();
  if (kept.dropped > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: dropped %zu contour(s)%s\n", kept.dropped,
                 o.largest ? " (keeping the largest only)" : (" shorter than " + std::to_string(o.min_linels) + " linels").c_str());
  if (fe.contours.contours.empty()) throw Error("no contour left (all shorter than --min-linels)");
  progress.start("normals");
  fe.normals = o.normals == "exact" ? exact_normals(*fe.shape, fe.contours, o.length_scale)
                                    : ii_normals(fe.set, fe.contours, IINormalOptions{ii_k_R(o.k_R, 1), o.length_scale, o.length_quantile});
  fe.seconds_normals = progress.finish();
  progress.start("measures");
  fe.measures = measures(fe.contours, fe.normals);
  fe.seconds_measures = progress.finish();
  if (!progress.quiet())
    std::fprintf(stderr, "length scale l = %.6g%s, II radius R = %.6g\n", fe.measures.length_scale,
                 o.length_scale > 0 ? " (given)" : " (measured)", fe.measures.normal_radius);
  if (fe.measures.clamped > 0 && !progress.quiet())
    std::fprintf(stderr, "warning: %zu linels got mu = 0 (normal orthogonal to the linel); k_R may be too large\n",
                 fe.measures.clamped);
  return fe;
}

ContourOperator build_operator(const FrontEnd& fe, const HeatLaplacianOptions& options, Progress& progress) {
  progress.start("operator");
  ContourOperator op = heat_laplacian(fe.contours, fe.measures, options);
  progress.finish();
  return op;
}

}  // namespace digilap::app
