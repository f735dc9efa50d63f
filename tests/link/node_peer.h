// Test fixture for tests that run a node-mavlink peer script from tools/node (node and its node_modules
// are required: when missing the test fails with a message pointing to `make setup`, it does not skip).
// The build defines QUAD_NODE_EXECUTABLE and QUAD_NODE_DIR (tests/link/CMakeLists.txt).
#pragma once

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace quad {
namespace mavlink {
namespace testing {

inline std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Checks node and node-mavlink, gives each test a scratch directory (kept when the test fails).
class NodePeerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(node_.empty() || node_.find("NOTFOUND") != std::string::npos)
        << "node was not found when CMake configured the build; install it with `make setup`";
    ASSERT_EQ(access(node_.c_str(), X_OK), 0) << "cannot execute node at " << node_;
    const std::string module = node_dir_ + "/node_modules/node-mavlink/package.json";
    ASSERT_EQ(access(module.c_str(), R_OK), 0)
        << module << " is missing: node-mavlink is not installed; run `make setup` (npm ci in tools/node)";
    char pattern[] = "/tmp/quad_link_node_XXXXXX";
    ASSERT_NE(mkdtemp(pattern), nullptr);
    dir_ = pattern;
  }
  void TearDown() override {
    if (!dir_.empty() && !HasFailure()) std::system(("rm -rf '" + dir_ + "'").c_str());
  }

  // Runs tools/node/<script> with `arguments`; on failure reports its exit status and stderr.
  void run_peer(const std::string& script, const std::string& arguments) {
    const std::string err = dir_ + "/node.stderr";
    const std::string command =
        "'" + node_ + "' '" + node_dir_ + "/" + script + "' " + arguments + " 2>'" + err + "'";
    const int status = std::system(command.c_str());
    ASSERT_EQ(status, 0) << command << "\n" << read_file(err);
  }

  std::string dir_;

 private:
  const std::string node_ = QUAD_NODE_EXECUTABLE;
  const std::string node_dir_ = QUAD_NODE_DIR;
};

}  // namespace testing
}  // namespace mavlink
}  // namespace quad
