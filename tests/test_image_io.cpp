// EXR round trip and the PNG preview's encoding.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "film/image_io.h"

namespace {

namespace fs = std::filesystem;

TEST(ImageIo, ExrRoundTripIsExact) {
  spm::Image img;
  img.width = 37;
  img.height = 23;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1e4f);
  for (int i = 0; i < img.width * img.height * 3; ++i) img.rgb.push_back(u(rng));
  const fs::path dir = fs::temp_directory_path() / ("spm_test_exr_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "round.exr").string();
  spm::write_exr(path, img);
  const spm::Image back = spm::read_exr(path);
  ASSERT_EQ(back.width, img.width);
  ASSERT_EQ(back.height, img.height);
  EXPECT_EQ(back.rgb, img.rgb);  // 32-bit float channels: bit-exact
  // Nothing but the final file is left in the directory.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().filename() == "round.exr" ? 1 : 100;
  EXPECT_EQ(files, 1);
  fs::remove_all(dir);
}

TEST(ImageIo, SrgbEncoding) {
  EXPECT_EQ(spm::to_srgb8(0.0f), 0);
  EXPECT_EQ(spm::to_srgb8(1.0f), 255);
  EXPECT_EQ(spm::to_srgb8(5.0f), 255);     // clamped
  EXPECT_EQ(spm::to_srgb8(-1.0f), 0);
  EXPECT_EQ(spm::to_srgb8(0.5f), 188);     // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
  EXPECT_EQ(spm::to_srgb8(0.002f), 7);     // linear segment: 12.92 * 0.002 * 255 = 6.6
}

TEST(ImageIo, ReadingAMissingExrIsAnInputError) {
  EXPECT_THROW(spm::read_exr("/nonexistent/file.exr"), std::exception);
}

}  // namespace
