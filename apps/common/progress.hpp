// What the apps tell the user on stderr: stage timing, progress bars (silent with --quiet), and
// errors turned into a message and exit code 1.
#pragma once

#include <chrono>
#include <functional>
#include <string>

namespace digilap::app {

/// Progress and stage timing on stderr; silent with --quiet.
class Progress {
public:
  explicit Progress(bool quiet) : quiet_(quiet) {}
  bool quiet() const { return quiet_; }
  /// Starts a stage ("normals"); finish() prints its time.
  void start(const std::string& stage);
  double finish();
  /// A progress bar for long loops: "label [#####.....]  42%".
  void bar(const std::string& label, double fraction);
  void end_bar();

private:
  bool quiet_;
  std::string stage_;
  std::chrono::steady_clock::time_point t0_;
};

/// Runs `body`, turning digilap::Error and std::exception into "error: ..." and exit code 1.
int guarded_main(const std::function<int()>& body);

}  // namespace digilap::app
