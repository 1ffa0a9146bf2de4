// surface/ply.hpp: the surfels as a quad mesh with the surface's topology, in the PLY layout.
#include "digilap/surface/ply.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <tuple>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// The surfels as a quad mesh: corners shared, so the Euler characteristic V - E + F (E = 2F
// for a closed quad mesh) is the surface's: 2 for the sphere and the ellipsoid, 0 for the torus.
// The file's header and size follow the PLY layout. (The torus is taken at h = 0.07: at 0.1 and
// 0.05 its digitization has a voxel meeting another by an edge only, where the quad mesh pinches
// and V - F is -1: a digital, not a continuous, surface.)
TEST(Surface, PlyQuadMeshHasTheTopologyOfTheSurface) {
  const std::string dir = ::testing::TempDir();
  for (const auto& [name, euler, h] : {std::tuple<const char*, long, double>{"sphere", 2, 0.1}, {"ellipsoid", 2, 0.1}, {"torus", 0, 0.07}}) {
    const auto s = posed(make_surface(name));
    const SurfelSet f = extract_surfels(digitize(*s, h));
    const Eigen::VectorXd mu = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(f.size()), 0.01);
    const std::string path = dir + "/" + name + ".ply";
    const PlyMeshSize size = save_ply(f, {{"mu", mu}, {"phi_1", mu}}, path);
    EXPECT_EQ(size.faces, f.size());
    EXPECT_EQ(static_cast<long>(size.vertices) - static_cast<long>(size.faces), euler) << name;
    std::ifstream in(path, std::ios::binary);
    std::string header, line;
    while (std::getline(in, line) && line != "end_header") header += line + "\n";
    EXPECT_NE(header.find("element face " + std::to_string(f.size())), std::string::npos);
    EXPECT_NE(header.find("property float phi_1"), std::string::npos);
    in.seekg(0, std::ios::end);
    const auto bytes = static_cast<std::size_t>(in.tellg()) - header.size() - std::string("end_header\n").size();
    EXPECT_EQ(bytes, 12 * size.vertices + (1 + 16 + 8) * size.faces);
  }
  const SurfelSet f = extract_surfels(digitize(Sphere(), 0.5));
  EXPECT_THROW(save_ply(f, {{"bad name", Eigen::VectorXd::Zero(static_cast<Eigen::Index>(f.size()))}}, dir + "/x.ply"), Error);
  EXPECT_THROW(save_ply(f, {{"mu", Eigen::VectorXd::Zero(3)}}, dir + "/x.ply"), Error);
}
