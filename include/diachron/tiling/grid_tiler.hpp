#pragma once
/// @file
/// GridTiler: cuts an image into a regular grid of tiles, each with a core (the pixels the tile
/// owns) and a buffered rectangle (the core plus a margin, the pixels a matcher sees).
///
/// Relation to MicMac's GetPatchPair (reference/micmac-tiephistorical.md, sections 2-3):
/// - MicMac's Guided mode places patch m at origin m * core - buffer with size core + 2 * buffer
///   and makes ceil(Img / Core) patches per axis. GridTiler uses exactly this layout, then clips
///   the buffered rectangle at the image borders (MicMac pads instead), and shortens the last core
///   to the image border.
/// - MicMac's BruteForce mode makes int(Img / Core) + 1 patches per axis. When Img is a multiple of
///   Core this adds a last patch that starts at the image border and holds no pixel; GridTiler never
///   makes that empty tile. Otherwise both counts agree.
/// - MicMac's MergeTiePt keeps a match only when its master point falls in the patch core;
///   one_to_many.hpp does the same with Tile::core.
/// Because the cores are the cells of a partition, every image pixel lies in exactly one tile core,
/// and the strip left over at the right and bottom borders becomes a (narrower) last tile.

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>

namespace diachron {

/// An axis-aligned rectangle of whole pixels: columns [x, x + width), rows [y, y + height).
/// With the pixel-centre convention (docs/conventions.md) pixel i covers [i - 0.5, i + 0.5), so
/// the rectangle covers the continuous area [x - 0.5, x + width - 0.5) x [y - 0.5, y + height - 0.5).
struct PixelRect {
  int x = 0;       ///< first column, px
  int y = 0;       ///< first row, px
  int width = 0;   ///< columns, px (>= 0)
  int height = 0;  ///< rows, px (>= 0)

  int right() const { return x + width; }    ///< one past the last column
  int bottom() const { return y + height; }  ///< one past the last row
  bool empty() const { return width <= 0 || height <= 0; }
  std::size_t area() const {
    return empty() ? 0 : static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  }

  /// True when the integer pixel (px, py) is one of the rectangle's pixels.
  bool contains(int px, int py) const { return px >= x && py >= y && px < right() && py < bottom(); }

  /// True when the continuous point `p` (pixel-centre convention) lies in the area of one of the
  /// rectangle's pixels. Half-open, so adjacent rectangles never both contain a point; NaN is
  /// contained nowhere.
  bool contains(const Eigen::Vector2d& p) const {
    return p.x() >= x - 0.5 && p.x() < right() - 0.5 && p.y() >= y - 0.5 && p.y() < bottom() - 0.5;
  }

  /// The common part of two rectangles (width/height 0 when they do not overlap).
  PixelRect intersect(const PixelRect& other) const {
    const int x0 = x > other.x ? x : other.x;
    const int y0 = y > other.y ? y : other.y;
    const int x1 = right() < other.right() ? right() : other.right();
    const int y1 = bottom() < other.bottom() ? bottom() : other.bottom();
    if (x1 <= x0 || y1 <= y0) return PixelRect{x0, y0, 0, 0};
    return PixelRect{x0, y0, x1 - x0, y1 - y0};
  }

  bool operator==(const PixelRect& o) const {
    return x == o.x && y == o.y && width == o.width && height == o.height;
  }
  bool operator!=(const PixelRect& o) const { return !(*this == o); }
};

/// Tile layout. The defaults are MicMac's rough co-registration (CoRegPatchSz [1920, 1440], no
/// buffer); `micmac_precise()` gives the precise-matching layout with a 10 % buffer per side.
struct GridTilerOptions {
  int tile_width = 1920;   ///< full tile width including both buffers, px (> 2 * buffer_x)
  int tile_height = 1440;  ///< full tile height including both buffers, px (> 2 * buffer_y)
  int buffer_x = 0;        ///< margin on the left and on the right of each core, px (>= 0)
  int buffer_y = 0;        ///< margin above and below each core, px (>= 0)

  int core_width() const { return tile_width - 2 * buffer_x; }    ///< px
  int core_height() const { return tile_height - 2 * buffer_y; }  ///< px

  /// MicMac HEAD rough co-registration: 1920 x 1440 tiles, no buffer.
  static GridTilerOptions micmac_rough() { return GridTilerOptions{}; }
  /// MicMac HEAD precise matching: 1920 x 1440 tiles, buffer 192 x 144 (core 1536 x 1152).
  static GridTilerOptions micmac_precise() { return GridTilerOptions{1920, 1440, 192, 144}; }
  /// The paper era's tiles (640 x 480, no buffer).
  static GridTilerOptions paper_rough() { return GridTilerOptions{640, 480, 0, 0}; }

  void check() const {
    DIACHRON_CHECK(tile_width > 0 && tile_height > 0,
                   "tile size must be positive, got " << tile_width << " x " << tile_height);
    DIACHRON_CHECK(buffer_x >= 0 && buffer_y >= 0,
                   "tile buffer must be non-negative, got " << buffer_x << " x " << buffer_y);
    DIACHRON_CHECK(core_width() > 0 && core_height() > 0,
                   "tile core (tile - 2 * buffer) must be positive, got "
                       << core_width() << " x " << core_height() << " for tile " << tile_width
                       << " x " << tile_height << " and buffer " << buffer_x << " x " << buffer_y);
  }
};

/// One tile of a grid.
struct Tile {
  std::size_t index = 0;  ///< row-major position in the grid: row * columns + column
  int column = 0;         ///< grid column (0 = leftmost)
  int row = 0;            ///< grid row (0 = top)
  PixelRect core;         ///< the pixels this tile owns; the cores partition the image
  PixelRect buffered;     ///< core plus buffer, clipped to the image: the pixels to crop and match
};

/// Cuts images into a core + buffer grid (see the file comment for MicMac's conventions).
/// Stateless apart from its options: const and safe to share between threads.
class GridTiler {
 public:
  /// Throws diachron::Error when the options are invalid (see GridTilerOptions::check).
  explicit GridTiler(const GridTilerOptions& options = {}) : options_(options) { options_.check(); }

  const GridTilerOptions& options() const { return options_; }

  /// Tile columns for an image `image_width` px wide: ceil(width / core_width), 0 for an empty image.
  int columns(int image_width) const { return count(image_width, options_.core_width()); }
  /// Tile rows for an image `image_height` px high: ceil(height / core_height), 0 for an empty image.
  int rows(int image_height) const { return count(image_height, options_.core_height()); }

  /// All tiles of a `image_width` x `image_height` image, in row-major order (index == position).
  /// An image smaller than one core gives one tile covering it; an empty image gives no tile.
  /// Throws diachron::Error for negative sizes.
  std::vector<Tile> tiles(int image_width, int image_height) const {
    check_size(image_width, image_height);
    const int nx = columns(image_width), ny = rows(image_height);
    std::vector<Tile> out;
    out.reserve(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
    for (int r = 0; r < ny; ++r)
      for (int c = 0; c < nx; ++c) out.push_back(make_tile(c, r, nx, image_width, image_height));
    return out;
  }

  /// The tile at grid column `column`, row `row` of an image of the given size. Throws
  /// diachron::Error when the cell is outside the grid.
  Tile tile(int column, int row, int image_width, int image_height) const {
    check_size(image_width, image_height);
    const int nx = columns(image_width), ny = rows(image_height);
    DIACHRON_CHECK(column >= 0 && row >= 0 && column < nx && row < ny,
                   "tile (" << column << ", " << row << ") outside a " << nx << " x " << ny << " grid");
    return make_tile(column, row, nx, image_width, image_height);
  }

  /// Index of the tile whose core contains the continuous point `p` (pixel-centre convention),
  /// or nullopt when `p` is outside the image area [-0.5, width - 0.5) x [-0.5, height - 0.5).
  std::optional<std::size_t> tile_index_at(const Eigen::Vector2d& p, int image_width,
                                           int image_height) const {
    check_size(image_width, image_height);
    if (!(p.x() >= -0.5 && p.x() < image_width - 0.5 && p.y() >= -0.5 && p.y() < image_height - 0.5))
      return std::nullopt;
    // Pixel i covers [i - 0.5, i + 0.5): floor(p + 0.5) is the pixel, pixel / core the cell.
    const int px = static_cast<int>(p.x() + 0.5), py = static_cast<int>(p.y() + 0.5);
    const int c = px / options_.core_width(), r = py / options_.core_height();
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(columns(image_width)) +
           static_cast<std::size_t>(c);
  }

 private:
  static int count(int image_size, int core) {
    if (image_size <= 0) return 0;
    return (image_size - 1) / core + 1;  // ceil without overflow
  }

  static void check_size(int w, int h) {
    DIACHRON_CHECK(w >= 0 && h >= 0, "image size must be non-negative, got " << w << " x " << h);
  }

  // Clips [start, start + length) to [0, limit) along one axis.
  static void clip(int start, int length, int limit, int& out_start, int& out_length) {
    const long long s = start < 0 ? 0 : start;
    long long e = static_cast<long long>(start) + length;
    if (e > limit) e = limit;
    out_start = static_cast<int>(s);
    out_length = e > s ? static_cast<int>(e - s) : 0;
  }

  Tile make_tile(int c, int r, int nx, int w, int h) const {
    const int cw = options_.core_width(), ch = options_.core_height();
    Tile t;
    t.index = static_cast<std::size_t>(r) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(c);
    t.column = c;
    t.row = r;
    clip(c * cw, cw, w, t.core.x, t.core.width);
    clip(r * ch, ch, h, t.core.y, t.core.height);
    // MicMac's patch origin m * core - buffer, tile-sized, then clipped to the image.
    clip(c * cw - options_.buffer_x, options_.tile_width, w, t.buffered.x, t.buffered.width);
    clip(r * ch - options_.buffer_y, options_.tile_height, h, t.buffered.y, t.buffered.height);
    return t;
  }

  GridTilerOptions options_;
};

}  // namespace diachron
