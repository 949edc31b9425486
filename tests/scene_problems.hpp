// Helpers of the scene tests (tests/runtime/test_scene.cpp, test_scene_keys.cpp): the
// problems a scene that must fail reports, and matching them.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "runtime/scene.hpp"

namespace hardrod::testing {

// The problems of a scene that must fail; fails the test if it parses.
inline std::vector<std::string> problems_of(const std::string &text,
                                            const std::vector<std::string> &overrides = {}) {
  try {
    parse_scene(text, overrides);
  } catch (const SceneError &error) {
    return error.problems();
  }
  ADD_FAILURE() << "scene parsed but should not have:\n" << text;
  return {};
}

inline bool contains(const std::vector<std::string> &problems, const std::string &fragment) {
  return std::any_of(problems.begin(), problems.end(), [&](const std::string &problem) {
    return problem.find(fragment) != std::string::npos;
  });
}

// The problems, one per line, for a failure message.
inline std::string lines(const std::vector<std::string> &problems) {
  std::string text;
  for (const auto &problem : problems) text += "  " + problem + "\n";
  return text;
}

}  // namespace hardrod::testing
