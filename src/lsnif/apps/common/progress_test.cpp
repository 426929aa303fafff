// progress_test.cpp -- the progress bar's last line: work that completed ends at 100%, work that
// stopped early (a training run that diverged) at the count it reached.
#include "lsnif/apps/common/progress.h"

#include <gtest/gtest.h>

#include <string>

namespace lsnif {
namespace {

// The last line the bar draws on stderr for `done` units of 200 reported, then finish(status).
std::string final_line(uint64_t done, const std::string& status) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("train", 200);
    for (uint64_t k = 1; k <= done; ++k) bar.update(k, "loss 0.5");
    bar.finish(status);
  }
  std::string text = testing::internal::GetCapturedStderr();
  while (!text.empty() && text.back() == '\n') text.pop_back();
  const size_t cut = text.find_last_of("\n\r");
  return cut == std::string::npos ? text : text.substr(cut + 1);
}

TEST(ProgressBar, EndsWhereTheWorkStopped) {
  const std::string failed = final_line(2, "failed");
  EXPECT_NE(failed.find(" 2/200 "), std::string::npos) << failed;
  EXPECT_NE(failed.find("failed"), std::string::npos) << failed;
  EXPECT_EQ(failed.find("100%"), std::string::npos) << failed;
  const std::string none = final_line(0, "failed");
  EXPECT_NE(none.find(" 0/200 "), std::string::npos) << none;
  const std::string done = final_line(200, "1000 rays/s");
  EXPECT_NE(done.find("100% 200/200"), std::string::npos) << done;
}

TEST(ProgressBar, DisabledDrawsNothing) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("train", 10, false);
    bar.update(5);
    bar.finish("failed");
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace lsnif
