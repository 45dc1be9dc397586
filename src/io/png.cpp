// PNG through libpng's low-level API with memory callbacks. libpng reports errors by longjmp;
// every libpng call sits in a small function that owns the setjmp and holds no C++ object with
// a destructor, so no destructor is skipped when libpng jumps out. Messages are copied into a
// plain buffer and turned into exceptions after the jump.
#include "rangeseg/io/png.hpp"

#include <png.h>

#include <array>
#include <csetjmp>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

struct ErrorSink {
  char message[256] = "unknown libpng error";
};

void png_error_to_sink(png_structp png, png_const_charp message) {
  auto* sink = static_cast<ErrorSink*>(png_get_error_ptr(png));
  if (sink != nullptr) std::snprintf(sink->message, sizeof sink->message, "%s", message);
  png_longjmp(png, 1);
}
void png_ignore_warning(png_structp, png_const_charp) {}

// ---------------------------------------------------------------- reading

struct MemoryReader {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  std::size_t pos = 0;
};

void png_read_from_memory(png_structp png, png_bytep out, png_size_t length) {
  auto* reader = static_cast<MemoryReader*>(png_get_io_ptr(png));
  if (length > reader->size - reader->pos) png_error(png, "file is truncated");
  std::memcpy(out, reader->data + reader->pos, length);
  reader->pos += length;
}

struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, colour_type = 0;
};

// Reads the signature and header chunks; returns false with the message in `sink` on error.
bool read_header(png_structp png, png_infop info, PngHeader* header) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  int interlace = 0;
  png_get_IHDR(png, info, &header->width, &header->height, &header->bit_depth, &header->colour_type,
               &interlace, nullptr, nullptr);
  return true;
}

bool read_rows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

std::string colour_type_name(int colour_type) {
  switch (colour_type) {
    case PNG_COLOR_TYPE_GRAY:
      return "grayscale";
    case PNG_COLOR_TYPE_RGB:
      return "RGB";
    case PNG_COLOR_TYPE_PALETTE:
      return "palette";
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return "grayscale+alpha";
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return "RGBA";
    default:
      return "colour type " + std::to_string(colour_type);
  }
}

// Decodes an 8- or 16-bit grayscale PNG into `out` (resized), widening 8-bit values.
template <class T>
void decode_gray(const std::uint8_t* data, std::size_t size, const std::string& name, Plane<T>& out,
                 bool* eight_bit = nullptr) {
  const auto fail = [&](const std::string& why) -> std::runtime_error {
    return std::runtime_error("PNG '" + name + "': " + why);
  };
  if (size == 0) throw fail("empty file (0 bytes)");
  if (data == nullptr || size < 8 || png_sig_cmp(data, 0, 8) != 0) {
    throw fail("not a PNG file (bad signature)");
  }

  // libpng allocates a chunk's declared length before reading it; a lying length could make it
  // allocate far more than the file holds, so every chunk must fit in the file first.
  for (std::size_t pos = 8; pos + 8 <= size;) {
    const std::uint64_t length = (std::uint64_t{data[pos]} << 24) |
                                 (std::uint64_t{data[pos + 1]} << 16) |
                                 (std::uint64_t{data[pos + 2]} << 8) | data[pos + 3];
    if (length + 12 > size - pos) {
      throw fail("chunk at byte " + std::to_string(pos) + " declares " + std::to_string(length) +
                 " bytes but only " + std::to_string(size - pos) +
                 " remain (truncated or corrupt)");
    }
    if (std::memcmp(data + pos + 4, "IEND", 4) == 0) break;
    pos += static_cast<std::size_t>(length) + 12;
  }

  ErrorSink sink;
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &sink, png_error_to_sink, png_ignore_warning);
  if (png == nullptr) throw fail("cannot create libpng reader");
  png_infop info = png_create_info_struct(png);
  struct Guard {
    png_structp* png;
    png_infop* info;
    ~Guard() { png_destroy_read_struct(png, info, nullptr); }
  } guard{&png, &info};
  if (info == nullptr) throw fail("cannot create libpng info");

  MemoryReader reader{data, size, 0};
  png_set_read_fn(png, &reader, png_read_from_memory);
  // Bounds on header sizes and on memory for ancillary chunks (compressed text, ICC profiles).
  png_set_user_limits(png, 1u << 20, 1u << 20);
  png_set_chunk_malloc_max(png, 8u << 20);

  PngHeader header;
  if (!read_header(png, info, &header)) throw fail(sink.message);
  if (header.colour_type != PNG_COLOR_TYPE_GRAY ||
      (header.bit_depth != 8 && header.bit_depth != 16)) {
    throw fail("expected 8- or 16-bit grayscale, got " + colour_type_name(header.colour_type) +
               " with " + std::to_string(header.bit_depth) + " bits per sample");
  }
  const std::uint64_t pixels = std::uint64_t{header.width} * header.height;
  if (header.width == 0 || header.height == 0 || pixels > kMaxPngPixels) {
    throw fail("image size " + std::to_string(header.width) + " x " +
               std::to_string(header.height) + " is empty or larger than the limit of " +
               std::to_string(kMaxPngPixels) + " pixels");
  }
  if (eight_bit != nullptr) *eight_bit = header.bit_depth == 8;
  const std::size_t bytes_per_sample = header.bit_depth / 8;
  const std::size_t row_bytes = header.width * bytes_per_sample;
  // Deflate cannot compress better than 1032:1, so a header promising more filtered image bytes
  // than the file could expand to is a lie; refusing it avoids allocating for it.
  const std::uint64_t filtered_bytes = std::uint64_t{header.height} * (row_bytes + 1);
  if (filtered_bytes > 1100 * std::uint64_t{size} + 65536) {
    throw fail("header promises " + std::to_string(header.width) + " x " +
               std::to_string(header.height) + " pixels but the file has only " +
               std::to_string(size) + " bytes (truncated or corrupt)");
  }

  std::vector<std::uint8_t> buffer(row_bytes * header.height);
  std::vector<png_bytep> rows(header.height);
  for (png_uint_32 y = 0; y < header.height; ++y) rows[y] = buffer.data() + y * row_bytes;
  if (!read_rows(png, info, rows.data())) throw fail(sink.message);

  const int width = static_cast<int>(header.width);
  const int height = static_cast<int>(header.height);
  out.resize(width, height);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* src = rows[y];
    T* dst = out.row(y);
    if (bytes_per_sample == 2) {
      for (int x = 0; x < width; ++x) {
        const std::ptrdiff_t i = 2 * static_cast<std::ptrdiff_t>(x);
        dst[x] = static_cast<T>((static_cast<unsigned>(src[i]) << 8) | src[i + 1]);
      }
    } else {
      for (int x = 0; x < width; ++x) dst[x] = static_cast<T>(src[x]);
    }
  }
}

// ---------------------------------------------------------------- writing

struct MemoryWriter {
  std::vector<std::uint8_t>* bytes = nullptr;
};

void png_write_to_memory(png_structp png, png_bytep in, png_size_t length) {
  auto* writer = static_cast<MemoryWriter*>(png_get_io_ptr(png));
  try {
    writer->bytes->insert(writer->bytes->end(), in, in + length);
  } catch (const std::bad_alloc&) {
    png_error(png, "out of memory while encoding");
  }
}
void png_flush_nothing(png_structp) {}

bool write_png(png_structp png, png_infop info, png_uint_32 width, png_uint_32 height,
               int bit_depth, int colour_type, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  // zlib level 1 without row filters: 5-9x faster than libpng's defaults (level 6, a filter
  // chosen per row) on this library's pictures, label and depth images, and the flat-coloured
  // pictures come out smaller too (overlay 431 -> 288 KB); a depth PNG of a real sensor grows
  // ~20 %. Writing the pictures had dominated `rangeseg segment` (~100 ms a frame).
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  png_set_IHDR(png, info, width, height, bit_depth, colour_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // Names the writer, as the PLY, OBJ and PCD headers do: the command line removes only result
  // files it recognises as its own.
  std::array<char, 9> key{"Software"}, value{"rangeseg"};
  png_text text{};
  text.compression = PNG_TEXT_COMPRESSION_NONE;
  text.key = key.data();
  text.text = value.data();
  text.text_length = value.size() - 1;
  png_set_text(png, info, &text, 1);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

// `rows` point to big-endian samples ready for libpng.
std::vector<std::uint8_t> encode(int width, int height, int bit_depth, int colour_type,
                                 std::vector<std::uint8_t>& pixels, std::size_t row_bytes) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("PNG encode: empty image " + std::to_string(width) + " x " +
                                std::to_string(height));
  }
  std::vector<std::uint8_t> bytes;
  bytes.reserve(pixels.size() / 2 + 1024);
  std::vector<png_bytep> rows(height);
  for (int y = 0; y < height; ++y) rows[y] = pixels.data() + y * row_bytes;

  ErrorSink sink;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, png_error_to_sink, png_ignore_warning);
  if (png == nullptr) throw std::runtime_error("PNG encode: cannot create libpng writer");
  png_infop info = png_create_info_struct(png);
  struct Guard {
    png_structp* png;
    png_infop* info;
    ~Guard() { png_destroy_write_struct(png, info); }
  } guard{&png, &info};
  if (info == nullptr) throw std::runtime_error("PNG encode: cannot create libpng info");
  MemoryWriter writer{&bytes};
  png_set_write_fn(png, &writer, png_write_to_memory, png_flush_nothing);
  if (!write_png(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
                 bit_depth, colour_type, rows.data())) {
    throw std::runtime_error(std::string("PNG encode: ") + sink.message);
  }
  return bytes;
}

std::vector<std::uint8_t> encode_gray16(View<const std::uint16_t> image) {
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * 2;
  std::vector<std::uint8_t> pixels(row_bytes * std::max(image.height, 0));
  for (int y = 0; y < image.height; ++y) {
    const std::uint16_t* src = image.row(y);
    std::uint8_t* dst = pixels.data() + y * row_bytes;
    for (int x = 0; x < image.width; ++x) {
      const std::ptrdiff_t i = 2 * static_cast<std::ptrdiff_t>(x);
      dst[i] = static_cast<std::uint8_t>(src[x] >> 8);
      dst[i + 1] = static_cast<std::uint8_t>(src[x] & 0xff);
    }
  }
  return encode(image.width, image.height, 16, PNG_COLOR_TYPE_GRAY, pixels, row_bytes);
}

}  // namespace

DepthImage decode_depth_png(const std::uint8_t* data, std::size_t size, const std::string& name,
                            bool* eight_bit) {
  DepthImage image;
  decode_gray(data, size, name, image, eight_bit);
  return image;
}

DepthImage read_depth_png(const std::string& path, bool* eight_bit) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  return decode_depth_png(bytes.data(), bytes.size(), path, eight_bit);
}

LabelImage read_label_png(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  LabelImage labels;
  decode_gray(bytes.data(), bytes.size(), path, labels);
  return labels;
}

std::vector<std::uint8_t> encode_depth_png(View<const std::uint16_t> depth) {
  return encode_gray16(depth);
}

std::vector<std::uint8_t> encode_rgb_png(const RgbImage& image) {
  const std::size_t expected = static_cast<std::size_t>(std::max(image.width, 0)) *
                               static_cast<std::size_t>(std::max(image.height, 0)) * 3;
  if (image.rgb.size() != expected) {
    throw std::invalid_argument("RGB image " + std::to_string(image.width) + " x " +
                                std::to_string(image.height) + " holds " +
                                std::to_string(image.rgb.size()) + " bytes, expected " +
                                std::to_string(expected));
  }
  std::vector<std::uint8_t> pixels = image.rgb;
  return encode(image.width, image.height, 8, PNG_COLOR_TYPE_RGB, pixels,
                static_cast<std::size_t>(image.width) * 3);
}

void write_depth_png(const std::string& path, View<const std::uint16_t> depth) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode_gray16(depth);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("writing '" + path + "': " + e.what());
  }
  write_file_atomic(path, bytes);
}

void write_label_png(const std::string& path, const LabelImage& labels) {
  DepthImage narrow(labels.width(), labels.height());
  for (int y = 0; y < labels.height(); ++y) {
    const std::int32_t* src = labels.row(y);
    std::uint16_t* dst = narrow.row(y);
    for (int x = 0; x < labels.width(); ++x) {
      if (src[x] < 0 || src[x] > 65535) {
        throw std::invalid_argument("writing label PNG '" + path + "': label " +
                                    std::to_string(src[x]) + " at pixel (" + std::to_string(x) +
                                    ", " + std::to_string(y) + ") is outside 0..65535");
      }
      dst[x] = static_cast<std::uint16_t>(src[x]);
    }
  }
  write_depth_png(path, narrow.view());
}

void write_rgb_png(const std::string& path, const RgbImage& image) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode_rgb_png(image);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("writing '" + path + "': " + e.what());
  }
  write_file_atomic(path, bytes);
}

}  // namespace rangeseg::io
