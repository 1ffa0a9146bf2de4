// Internal: the parameters of a shape given as text ("R=1.5,v=0.3,k=4"), shared by the curves
// (make_shape) and the surfaces (make_surface).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace digilap::detail {

/// Reads `list` ("key=value,key=value") into `parameters`, whose keys (with their defaults, in
/// the order shown to users) are the only ones accepted. Throws digilap::Error naming the shape
/// for an unknown key (listing the known ones), a value that is not a finite number, or a key
/// given twice.
void read_shape_parameters(const std::string& shape, const std::string& list, std::vector<std::pair<std::string, double>>& parameters);

/// One line of --help: "name:key=default,key=default\n" (shape_syntax(), surface_syntax()).
std::string syntax_line(const char* name, const std::vector<std::pair<const char*, double>>& keys);
/// The value of `key` in `parameters` (which holds it).
double parameter(const std::vector<std::pair<std::string, double>>& parameters, const std::string& key);

}  // namespace digilap::detail
