#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/ply.hpp"
#include "test_util.hpp"

using namespace rangeseg;

namespace {

io::PlyMesh quad_mesh(bool normals, bool colours) {
  io::PlyMesh m;
  m.xyz = {0, 0, 1, 1, 0, 1, 1, 1, 1.5f, 0, 1, 1.25f};
  if (normals) m.normals = {0, 0, -1, 0, 0, -1, 0, 0.6f, -0.8f, 0, 0, -1};
  if (colours) m.rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 7, 8, 9};
  m.faces = {0, 1, 2, 0, 2, 3};
  return m;
}

}  // namespace

TEST(Ply, RoundTripAllLayouts) {
  const auto dir = test::scratch_dir("ply");
  for (int variant = 0; variant < 4; ++variant) {
    const io::PlyMesh m = quad_mesh(variant & 1, variant & 2);
    std::string file_name = "m";
    file_name += std::to_string(variant);
    file_name += ".ply";
    const std::string path = (dir / file_name).string();
    io::write_ply(path, m);
    const io::PlyMesh back = io::read_ply(path);
    EXPECT_EQ(back.xyz, m.xyz);
    EXPECT_EQ(back.normals, m.normals);
    EXPECT_EQ(back.rgb, m.rgb);
    EXPECT_EQ(back.faces, m.faces);
    EXPECT_EQ(back.vertices_per_face, 3);
  }
  io::PlyMesh quads = quad_mesh(false, false);
  quads.faces = {0, 1, 2, 3};
  quads.vertices_per_face = 4;
  const auto bytes = io::encode_ply(quads);
  const io::PlyMesh back = io::decode_ply(bytes.data(), bytes.size(), "q.ply");
  EXPECT_EQ(back.vertices_per_face, 4);
  EXPECT_EQ(back.faces, quads.faces);
}

TEST(Ply, StreamedFileEqualsTheInMemoryEncodingAcrossChunks) {
  // ~3.5 MB of vertices and faces: several 1 MB chunks, with a chunk border inside a record.
  io::PlyMesh m;
  const int n = 100003;
  for (int i = 0; i < n; ++i) {
    m.xyz.insert(m.xyz.end(), {0.001f * i, -0.002f * i, 1.0f + 1e-6f * i});
    m.normals.insert(m.normals.end(), {0.0f, 0.6f, -0.8f});
    m.rgb.insert(m.rgb.end(), {static_cast<std::uint8_t>(i), 1, 2});
  }
  for (int i = 0; i + 2 < n; ++i) m.faces.insert(m.faces.end(), {i, i + 1, i + 2});
  const auto dir = test::scratch_dir("ply_stream");
  const std::string path = (dir / "big.ply").string();
  io::write_ply(path, m);
  EXPECT_EQ(io::read_file(path), io::encode_ply(m));
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1) << "a temporary file was left behind";
}

TEST(Ply, WriterChecksItsLayoutAndLeavesNoFileWhenNotCommitted) {
  const auto dir = test::scratch_dir("ply_writer");
  const io::PlyMesh m = quad_mesh(true, true);
  const io::PlyLayout layout{.vertices = 4, .faces = 2, .normals = true, .rgb = true};
  const std::string path = (dir / "w.ply").string();
  {
    io::PlyWriter w(path, layout);
    for (std::size_t i = 0; i < 4; ++i) w.vertex(&m.xyz[3 * i], &m.normals[3 * i], &m.rgb[3 * i]);
    EXPECT_THROW(w.vertex(&m.xyz[0], &m.normals[0], &m.rgb[0]), std::invalid_argument);
    const std::int32_t outside[3] = {0, 1, 4};
    EXPECT_THROW(w.face(outside), std::invalid_argument);
    w.face(&m.faces[0]);
    EXPECT_THROW(w.commit(), std::logic_error);  // one face missing
    w.face(&m.faces[3]);
    EXPECT_THROW(w.face(&m.faces[0]), std::invalid_argument);
    w.commit();
  }
  EXPECT_EQ(io::read_file(path), io::encode_ply(m));
  {
    io::PlyWriter w((dir / "lacking.ply").string(), layout);
    EXPECT_THROW(w.vertex(&m.xyz[0], nullptr, &m.rgb[0]), std::invalid_argument);
    EXPECT_THROW(w.face(&m.faces[0]), std::invalid_argument);  // before the vertices
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "lacking.ply"));
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1) << "a temporary file was left behind";
  EXPECT_THROW(io::PlyWriter((dir / "x.ply").string(), {.vertices_per_face = 2}),
               std::invalid_argument);
}

TEST(Ply, AtomicFileWithoutCommitLeavesNothing) {
  const auto dir = test::scratch_dir("ply_atomic");
  const std::string path = (dir / "never.ply").string();
  {
    io::AtomicFile file(path);
    file.write("ply\n", 4);
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  io::AtomicFile file(path);
  file.write("abc", 3);
  file.commit();
  EXPECT_EQ(io::read_file(path).size(), 3u);
  EXPECT_THROW(file.commit(), std::runtime_error);
  EXPECT_THROW(file.write("x", 1), std::runtime_error);
}

// What a signal handler calls: the temporaries being written go, committed files stay, and a
// file whose temporary went cannot be committed.
TEST(Ply, RemoveTemporaryFilesRemovesOnlyUncommittedTemporaries) {
  const auto dir = test::scratch_dir("ply_atomic_signal");
  const std::string done = (dir / "done.ply").string();
  io::write_file_atomic(done, std::string("abc"));
  io::AtomicFile open_a((dir / "a.ply").string());
  io::AtomicFile open_b((dir / "b.ply").string());
  open_a.write("ply\n", 4);
  const auto count = [&] {
    return std::distance(std::filesystem::directory_iterator(dir),
                         std::filesystem::directory_iterator());
  };
  EXPECT_EQ(count(), 3);
  io::remove_temporary_files();
  EXPECT_EQ(count(), 1);
  EXPECT_EQ(io::read_file(done).size(), 3u);
  EXPECT_THROW(open_a.commit(), std::runtime_error);
  // Their slots are free again: a new file is tracked, and removed by the next call.
  io::AtomicFile next((dir / "c.ply").string());
  EXPECT_EQ(count(), 2);
  io::remove_temporary_files();
  EXPECT_EQ(count(), 1);
}

TEST(Ply, HeaderAndBinaryLayoutAreExactlyAsDocumented) {
  const io::PlyMesh m = quad_mesh(true, true);
  const std::vector<std::uint8_t> bytes = io::encode_ply(m);
  const std::string text(bytes.begin(), bytes.end());
  const std::string expected_header =
      "ply\nformat binary_little_endian 1.0\ncomment written by rangeseg\nelement vertex 4\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  ASSERT_EQ(text.substr(0, expected_header.size()), expected_header);
  const std::size_t body = expected_header.size();
  constexpr std::size_t kVertexBytes = 6 * 4 + 3;  // x y z nx ny nz (float), red green blue
  constexpr std::size_t kFaceBytes = 1 + 3 * 4;    // uchar count, 3 int indices
  ASSERT_EQ(bytes.size(), body + 4 * kVertexBytes + 2 * kFaceBytes);
  float z1 = 0;
  std::memcpy(&z1, bytes.data() + body + kVertexBytes + 8, 4);  // vertex 1, z
  EXPECT_EQ(z1, 1.0f);
  EXPECT_EQ(bytes[body + 3 * kVertexBytes + 24], 7);  // vertex 3, red
  const std::size_t faces = body + 4 * kVertexBytes;
  EXPECT_EQ(bytes[faces], 3);
  EXPECT_EQ(bytes[faces + kFaceBytes], 3);
  std::int32_t last = 0;
  std::memcpy(&last, bytes.data() + faces + kFaceBytes + 1 + 8, 4);
  EXPECT_EQ(last, 3);
}

TEST(Ply, InvalidMeshesAreRejectedWithValues) {
  const auto expect_invalid = [](const io::PlyMesh& m, const std::string& needle) {
    try {
      io::encode_ply(m);
      ADD_FAILURE() << "no exception for " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  io::PlyMesh m = quad_mesh(false, false);
  m.xyz.push_back(1);
  expect_invalid(m, "13");
  m = quad_mesh(false, false);
  m.normals = {0, 0, 1};
  expect_invalid(m, "normals");
  m = quad_mesh(false, false);
  m.rgb = {1, 2};
  expect_invalid(m, "rgb");
  m = quad_mesh(false, false);
  m.faces[4] = 4;
  expect_invalid(m, "index 4");
  m.faces[4] = -1;
  expect_invalid(m, "index -1");
  m = quad_mesh(false, false);
  m.faces.push_back(0);
  expect_invalid(m, "7");
  m.vertices_per_face = 2;
  expect_invalid(m, "vertices_per_face");
  EXPECT_THROW(io::write_ply("/tmp/rangeseg_never.ply", m), std::invalid_argument);
}

TEST(Ply, ReaderRejectsOtherLayoutsAndDamage) {
  const auto expect_bad = [](const std::string& text, const std::string& needle) {
    const std::vector<std::uint8_t> b(text.begin(), text.end());
    try {
      io::decode_ply(b.data(), b.size(), "bad.ply");
      ADD_FAILURE() << "no exception for " << needle;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("bad.ply"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_bad("not a ply", "not a PLY");
  expect_bad("ply\nformat ascii 1.0\nend_header\n", "ascii");
  expect_bad(
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
      "end_header\n",
      "float x");
  expect_bad(
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n1234",
      "truncated");
  expect_bad("ply\nformat binary_little_endian 1.0\nelement vertex 0\n", "end_header");

  const io::PlyMesh m = quad_mesh(false, false);
  std::vector<std::uint8_t> b = io::encode_ply(m);
  b.back() = 9;  // last index byte: vertex index 9 + 256 * 0 ... out of range
  EXPECT_THROW(io::decode_ply(b.data(), b.size(), "bad.ply"), std::runtime_error);
  b = io::encode_ply(m);
  for (std::size_t cut = 1; cut < 40; ++cut) {
    EXPECT_THROW(io::decode_ply(b.data(), b.size() - cut, "cut.ply"), std::runtime_error) << cut;
  }
}
