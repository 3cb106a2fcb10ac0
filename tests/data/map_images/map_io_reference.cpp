// The reference for tests/test_map_images.py: an image read the way Nav2's map_server reads it
// (nav2_map_server/src/map_io.cpp, Jazzy and newer), with the libraries it uses:
// GraphicsMagick's Magick++ for the image (grey conversion, alpha) and Eigen for the single-
// precision arithmetic of the thresholds. Written for the kit; it is not Nav2's code.
//
//   g++ -O2 -o map_io_reference map_io_reference.cpp -I/usr/include/eigen3 \
//       $(GraphicsMagick++-config --cppflags --cxxflags --ldflags --libs)
//   ./map_io_reference IMAGE [MODE NEGATE FREE OCCUPIED]...
//
// Prints "width height has_alpha", the greys, the alphas (if it has them), then one line per
// mode given: the cells. Every line is top row first.
#include <Magick++.h>
#include <Eigen/Dense>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using Bytes = Eigen::Array<uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Floats = Eigen::Array<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Cells = Eigen::Array<int8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

static Cells cells(const Bytes & grey, const Bytes * alpha, const std::string & mode,
                   bool negate, double free_thresh, double occupied_thresh)
{
  Cells out = Cells::Constant(grey.rows(), grey.cols(), -1);
  if (mode == "raw") {
    Cells as_int = grey.cast<int8_t>();
    return ((as_int < 0) || (as_int > 100)).select(Cells::Constant(grey.rows(), grey.cols(), -1),
                                                   as_int);
  }
  Floats p = grey.cast<float>() / 255.0f;
  if (!negate) {
    p = 1.0f - p;
  }
  const float occupied = static_cast<float>(occupied_thresh);
  const float free = static_cast<float>(free_thresh);
  out = (p >= occupied).select(Cells::Constant(p.rows(), p.cols(), 100), out);
  out = (p <= free).select(Cells::Constant(p.rows(), p.cols(), 0), out);
  if (mode == "scale") {
    const float span = static_cast<float>(occupied_thresh - free_thresh);
    Floats scaled = (p - free) / span * 100.0f;
    Cells rounded = scaled.round().cast<int8_t>();
    out = ((p > free) && (p < occupied)).select(rounded, out);
  }
  if (alpha != nullptr) {
    out = (*alpha < 255).select(Cells::Constant(p.rows(), p.cols(), -1), out);
  }
  return out;
}

static void print_line(const Eigen::Array<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> & a)
{
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    std::printf("%d%c", a.data()[k], k + 1 == a.size() ? '\n' : ' ');
  }
}

int main(int argc, char ** argv)
{
  if (argc < 2 || (argc - 2) % 4 != 0) {
    std::fprintf(stderr, "usage: %s IMAGE [MODE NEGATE FREE OCCUPIED]...\n", argv[0]);
    return 2;
  }
  Magick::InitializeMagick(nullptr);
  Magick::Image image(argv[1]);
  Magick::Image grey_image = image;
  grey_image.type(Magick::GrayscaleType);
  const size_t width = grey_image.columns(), height = grey_image.rows();
  Bytes grey(height, width), alpha(height, width);
  grey_image.write(0, 0, width, height, "I", Magick::CharPixel, grey.data());
  const bool has_alpha = image.matte();
  if (has_alpha) {
    image.write(0, 0, width, height, "A", Magick::CharPixel, alpha.data());
  }
  std::printf("%zu %zu %d\n", width, height, has_alpha ? 1 : 0);
  print_line(grey.cast<int>());
  if (has_alpha) {
    print_line(alpha.cast<int>());
  }
  for (int i = 2; i + 3 < argc; i += 4) {
    Cells c = cells(grey, has_alpha ? &alpha : nullptr, argv[i], std::atoi(argv[i + 1]) != 0,
                    std::atof(argv[i + 2]), std::atof(argv[i + 3]));
    print_line(c.cast<int>());
  }
  return 0;
}
