#include "shape_parameters.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>

namespace digilap::detail {

void read_shape_parameters(const std::string& shape, const std::string& list, std::vector<std::pair<std::string, double>>& parameters) {
  std::string keys;
  for (const auto& p : parameters) keys += (keys.empty() ? "" : ", ") + p.first;
  std::set<std::string> given;
  std::stringstream items(list);
  std::string item;
  while (std::getline(items, item, ',')) {
    const std::size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const auto slot = std::find_if(parameters.begin(), parameters.end(), [&](const auto& p) { return p.first == key; });
    if (eq == std::string::npos || slot == parameters.end())
      throw Error(shape + ": unknown parameter '" + key + "' (" + shape + " takes " + keys + ", as key=value separated by commas)");
    if (!given.insert(key).second) throw Error(shape + ": parameter '" + key + "' is given twice");
    const std::string text = item.substr(eq + 1);
    const char* first = text.data() + (!text.empty() && text[0] == '+' ? 1 : 0);
    double v = 0;
    const auto [end, ec] = std::from_chars(first, text.data() + text.size(), v);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v))
      throw Error(shape + ": " + key + " = '" + text + "' is not a finite number");
    slot->second = v;
  }
}

double parameter(const std::vector<std::pair<std::string, double>>& parameters, const std::string& key) {
  return std::find_if(parameters.begin(), parameters.end(), [&](const auto& p) { return p.first == key; })->second;
}

std::string syntax_line(const char* name, const std::vector<std::pair<const char*, double>>& keys) {
  std::string text = std::string(name) + ":";
  for (std::size_t i = 0; i < keys.size(); ++i) {
    std::ostringstream v;
    v << keys[i].second;
    text += std::string(i ? "," : "") + keys[i].first + "=" + v.str();
  }
  return text + "\n";
}

}  // namespace digilap::detail
