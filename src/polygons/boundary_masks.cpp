// Plane polygons: the per-vertex masks of outgoing boundary edges of every enabled segment, in
// one pass over the image.
//
// Per cell a byte tells which of its four sides (and its diagonal) are covered by a face of the
// cell's segment, and a side is a boundary edge when exactly one of the two cells sharing it
// covers it. Faces of different segments never share an edge (every corner of a face carries
// the face's label), so one outgoing-edge mask per vertex serves all segments at once.
//
// Two implementations with identical results: a scalar one (any stride, any CPU), and for
// pixel_stride 1 on CPUs with AVX2 a branch-free one that handles 16 cells (16-bit labels) or
// 32 vertices (bytes) per step. The vector path first maps each label row to 16 bits, 0 for
// labels of segments that are not outlined, so that the per-cell "all corners carry one enabled
// label" tests become 16-bit compares.
#include <algorithm>
#include <cassert>
#include <cstring>

#include "detail/headroom.hpp"
#include "detail/simd.hpp"
#include "polygons/internal.hpp"

namespace rangeseg::polygons_detail {
namespace {

// Per-cell coverage bits: sides (top a-b, bottom c-d, left a-c, right b-d) covered by a face of
// the cell's segment, and a diagonal covered by exactly one of the two triangles, with the
// direction in which that triangle traverses it.
constexpr std::uint8_t kT = 1, kB = 2, kL = 4, kR = 8;
constexpr std::uint8_t kDiagAD = 16, kDiagDA = 32, kDiagCB = 64, kDiagBC = 128;

constexpr std::uint8_t side_bits(int f) {
  if (f & face_bits::quad) return kT | kB | kL | kR;
  const bool t0 = f & face_bits::tri0, t1 = f & face_bits::tri1;
  int m = 0;
  if (!(f & face_bits::diag_bc)) {  // tri0 (a,d,b), tri1 (a,c,d)
    if (t0) m |= kT | kR;
    if (t1) m |= kL | kB;
    if (t0 && !t1) m |= kDiagAD;
    if (t1 && !t0) m |= kDiagDA;
  } else {  // tri0 (a,c,b), tri1 (b,c,d)
    if (t0) m |= kT | kL;
    if (t1) m |= kB | kR;
    if (t0 && !t1) m |= kDiagCB;
    if (t1 && !t0) m |= kDiagBC;
  }
  return static_cast<std::uint8_t>(m);
}
constexpr std::array<std::uint8_t, 16> make_side_table() {
  std::array<std::uint8_t, 16> t{};
  for (int f = 0; f < 16; ++f) t[f] = side_bits(f);
  return t;
}
alignas(16) constexpr std::array<std::uint8_t, 16> kSides = make_side_table();

// Cells per block of the uniform-label fast path of the scalar cell pass (stride 1).
constexpr int kBlock = 8;

// Outgoing boundary edges of a vertex from the coverage bits of its four cells: c00 up-left
// (vertex is its d), c01 up-right (its c), c10 down-left (its b), c11 down-right (its a).
inline std::uint8_t vertex_mask(unsigned c00, unsigned c01, unsigned c10, unsigned c11) {
  unsigned m = 0;
  m |= ((c01 & kB) && !(c11 & kT)) ? 1u : 0u;   // right: bottom side of c01
  m |= (c11 & kDiagAD) ? 2u : 0u;               // down-right: a -> d of c11
  m |= ((c11 & kL) && !(c10 & kR)) ? 4u : 0u;   // down: left side of c11
  m |= (c10 & kDiagBC) ? 8u : 0u;               // down-left: b -> c of c10
  m |= ((c10 & kT) && !(c00 & kB)) ? 16u : 0u;  // left: top side of c10
  m |= (c00 & kDiagDA) ? 32u : 0u;              // up-left: d -> a of c00
  m |= ((c00 & kR) && !(c01 & kL)) ? 64u : 0u;  // up: right side of c00
  m |= (c01 & kDiagCB) ? 128u : 0u;             // up-right: c -> b of c01
  return static_cast<std::uint8_t>(m);
}

// Coverage bits of the cells of row v (corners in rows v and v + s) into cur[0, width), 0 off
// the lattice's columns and past its last one.
void cell_row_scalar(View<const std::int32_t> labels, View<const std::uint8_t> faces, int s,
                     const std::uint8_t* en, std::size_t n_labels, int v, std::uint8_t* cur) {
  const int width = labels.width;
  const auto enabled = [en, n_labels](std::int32_t l) {
    return static_cast<std::size_t>(static_cast<std::uint32_t>(l)) < n_labels && en[l];
  };
  const int last_u = (width - 1) / s * s;
  if (v + s >= labels.height) {
    for (int u = 0; u < width; u += s) cur[u] = 0;
    return;
  }
  const std::int32_t* l0 = labels.row(v);
  const std::int32_t* l1 = labels.row(v + s);
  const std::uint8_t* f = faces.row(v);
  for (int u = 0; u + s < width; u += s) {
    if (s == 1 && u + kBlock < width) {
      // Most cells lie inside one segment (or outside all): kBlock cells whose kBlock + 1
      // corner columns in both rows carry one label take their faces' sides or nothing,
      // decided once for the block instead of per cell with branches on the labels.
      const std::int32_t label = l0[u];
      unsigned differ = 0;
      for (int i = 0; i <= kBlock; ++i) {
        differ |=
            static_cast<unsigned>(l0[u + i] ^ label) | static_cast<unsigned>(l1[u + i] ^ label);
      }
      if (differ == 0) {
        if (enabled(label)) {
          for (int i = 0; i < kBlock; ++i) cur[u + i] = kSides[f[u + i] & 15u];
        } else {
          std::memset(cur + u, 0, kBlock);
        }
        u += kBlock - 1;
        continue;
      }
    }
    const unsigned fb = f[u] & 15u;
    if (fb == 0) {
      cur[u] = 0;
      continue;
    }
    const std::int32_t la = l0[u], lb = l0[u + s], lc = l1[u], ld = l1[u + s];
    unsigned fe;
    if (la == lb && la == lc && la == ld) {
      fe = enabled(la) ? fb : 0u;
    } else if (fb & face_bits::quad) {
      fe = 0;
    } else {
      bool t0, t1;
      if (fb & face_bits::diag_bc) {
        t0 = la == lc && la == lb && enabled(la);
        t1 = lb == lc && lb == ld && enabled(lb);
      } else {
        t0 = la == ld && la == lb && enabled(la);
        t1 = la == lc && la == ld && enabled(la);
      }
      fe = (fb & face_bits::diag_bc) | (t0 ? (fb & face_bits::tri0) : 0u) |
           (t1 ? (fb & face_bits::tri1) : 0u);
    }
    cur[u] = kSides[fe];
  }
  cur[last_u] = 0;
}

void masks_scalar(View<const std::int32_t> labels, View<const std::uint8_t> faces, int s,
                  const std::uint8_t* en, std::size_t n_labels, std::uint16_t* edges,
                  std::ptrdiff_t stride, int v_begin, int v_end, std::vector<std::int32_t>& starts,
                  BoundaryMaskScratch& scratch) {
  const int width = labels.width;
  detail::assign_with_headroom(scratch.sides, 2 * static_cast<std::size_t>(width), 0);
  std::uint8_t* cur = scratch.sides.data();
  std::uint8_t* prev = cur + width;
  // A band's first vertex row needs the cells above it.
  if (v_begin > 0) cell_row_scalar(labels, faces, s, en, n_labels, v_begin - s, prev);
  for (int v = v_begin; v < v_end; v += s) {
    cell_row_scalar(labels, faces, s, en, n_labels, v, cur);
    std::uint16_t* mrow = edges + v * stride;
    for (int u = 0; u < width; u += s) {
      if (s == 1 && u >= 1 && u + 8 < width) {
        // Interior runs: 9 cells above and below all fully covered (or all empty) give no
        // boundary at the 8 vertices between them.
        std::uint64_t a, b, a1, b1;
        std::memcpy(&a, prev + u - 1, 8);
        std::memcpy(&b, cur + u - 1, 8);
        std::memcpy(&a1, prev + u, 8);
        std::memcpy(&b1, cur + u, 8);
        constexpr std::uint64_t kFull = 0x0F0F0F0F0F0F0F0Full;
        if ((a == kFull && b == kFull && a1 == kFull && b1 == kFull) ||
            (a == 0 && b == 0 && a1 == 0 && b1 == 0)) {
          u += 7;
          continue;
        }
      }
      const unsigned c11 = cur[u], c01 = prev[u];
      const unsigned c10 = u >= s ? cur[u - s] : 0u, c00 = u >= s ? prev[u - s] : 0u;
      if ((c00 | c01 | c10 | c11) == 0) continue;
      const std::uint8_t m = vertex_mask(c00, c01, c10, c11);
      if (m != 0) {
        mrow[u] = static_cast<std::uint16_t>(m * 257u);
        starts.push_back(static_cast<std::int32_t>(v * stride + u));
      }
    }
    std::swap(prev, cur);
  }
}

#if RANGESEG_SIMD_X86

// Vertices (bytes) per step; cells are done in two halves of 16 (16-bit labels).
constexpr int kChunk = 32;

// out[u] = the label at u if its segment is outlined, else 0, for u < width. `map` has
// n_labels + 1 entries: map[l] = l or 0, and map[n_labels] = 0 for labels out of range.
RANGESEG_SIMD_AVX2_TARGET void enabled_labels_avx2(const std::int32_t* labels, int width,
                                                   const std::int32_t* map, std::uint32_t n_labels,
                                                   std::uint16_t* out) {
  const __m256i last = _mm256_set1_epi32(static_cast<int>(n_labels));
  int u = 0;
  std::int32_t run_label = labels[0];
  const __m256i first = _mm256_set1_epi32(run_label);
  __m256i run = first;  // the label of the current run, in every lane
  __m256i run_value = _mm256_set1_epi16(
      static_cast<short>(map[std::min(static_cast<std::uint32_t>(run_label), n_labels)]));
  for (; u + 16 <= width; u += 16) {
    const __m256i a = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(labels + u));
    const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(labels + u + 8));
    // Long runs of one label are the rule: 16 labels equal to the run's need no look-up.
    const __m256i same = _mm256_and_si256(_mm256_cmpeq_epi32(a, run), _mm256_cmpeq_epi32(b, run));
    if (_mm256_movemask_epi8(same) == -1) {
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + u), run_value);
      continue;
    }
    // Labels out of [0, n_labels) (negative ones are large unsigned) read map[n_labels] = 0.
    const __m256i ga = _mm256_i32gather_epi32(map, _mm256_min_epu32(a, last), 4);
    const __m256i gb = _mm256_i32gather_epi32(map, _mm256_min_epu32(b, last), 4);
    const __m256i packed = _mm256_permute4x64_epi64(_mm256_packus_epi32(ga, gb), 0xD8);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + u), packed);
    run = _mm256_permutevar8x32_epi32(b, _mm256_set1_epi32(7));
    run_value = _mm256_set1_epi16(static_cast<short>(out[u + 15]));
  }
  for (; u < width; ++u) {
    out[u] =
        static_cast<std::uint16_t>(map[std::min(static_cast<std::uint32_t>(labels[u]), n_labels)]);
  }
}

RANGESEG_SIMD_AVX2_TARGET inline __attribute__((always_inline)) __m256i load16(
    const std::uint16_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}
RANGESEG_SIMD_AVX2_TARGET inline __attribute__((always_inline)) __m256i bit(__m256i x, int b) {
  return _mm256_and_si256(x, _mm256_set1_epi8(static_cast<char>(b)));
}

// Coverage bits of the cells between label rows e0 and e1 (enabled labels, zero in
// [width, width + kChunk]) into out[0, width) (written up to the next multiple of kChunk; the
// cell at width - 1 and the ones after get 0 from the zero labels).
RANGESEG_SIMD_AVX2_TARGET void cell_sides_avx2(const std::uint16_t* e0, const std::uint16_t* e1,
                                               const std::uint8_t* faces, int width,
                                               std::uint8_t* out) {
  const __m256i table =
      _mm256_broadcastsi128_si256(_mm_load_si128(reinterpret_cast<const __m128i*>(kSides.data())));
  const __m256i zero = _mm256_setzero_si256();
  const __m256i one = _mm256_set1_epi16(face_bits::tri0), two = _mm256_set1_epi16(face_bits::tri1);
  const __m256i quad = _mm256_set1_epi16(face_bits::quad);
  const __m256i diag = _mm256_set1_epi16(face_bits::diag_bc), low = _mm256_set1_epi16(15);
  alignas(32) std::uint8_t tail[kChunk];
  for (int u = 0; u < width; u += kChunk) {
    const std::uint8_t* f = faces + u;
    if (u + kChunk > width) {
      std::memset(tail, 0, sizeof tail);
      std::memcpy(tail, faces + u, static_cast<std::size_t>(width - u));
      f = tail;
    }
    {
      // Most chunks lie inside one segment or outside all: one label at all 33 corner columns
      // of both rows gives the faces' sides (label enabled) or nothing (label 0).
      const __m256i label = _mm256_set1_epi16(static_cast<short>(e0[u]));
      const __m256i same = _mm256_and_si256(
          _mm256_and_si256(_mm256_and_si256(_mm256_cmpeq_epi16(load16(e0 + u), label),
                                            _mm256_cmpeq_epi16(load16(e0 + u + 16), label)),
                           _mm256_and_si256(_mm256_cmpeq_epi16(load16(e0 + u + 17), label),
                                            _mm256_cmpeq_epi16(load16(e1 + u), label))),
          _mm256_and_si256(_mm256_cmpeq_epi16(load16(e1 + u + 16), label),
                           _mm256_cmpeq_epi16(load16(e1 + u + 17), label)));
      if (_mm256_movemask_epi8(same) == -1) {
        __m256i sides = zero;
        if (e0[u] != 0) {
          const __m256i fb = _mm256_and_si256(
              _mm256_loadu_si256(reinterpret_cast<const __m256i*>(f)), _mm256_set1_epi8(15));
          sides = _mm256_shuffle_epi8(table, fb);
        }
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + u), sides);
        continue;
      }
    }
    __m256i fe[2];
    for (std::ptrdiff_t h = 0; h < 2; ++h) {
      const std::uint16_t* a = e0 + u + 16 * h;
      const std::uint16_t* c = e1 + u + 16 * h;
      const __m256i ea = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a));
      const __m256i eb = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + 1));
      const __m256i ec = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c));
      const __m256i ed = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c + 1));
      const __m256i fb = _mm256_and_si256(
          _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(f + 16 * h))), low);
      const __m256i ab = _mm256_cmpeq_epi16(ea, eb), ac = _mm256_cmpeq_epi16(ea, ec);
      const __m256i ad = _mm256_cmpeq_epi16(ea, ed), bc = _mm256_cmpeq_epi16(eb, ec);
      const __m256i bd = _mm256_cmpeq_epi16(eb, ed);
      const __m256i za = _mm256_cmpeq_epi16(ea, zero), zb = _mm256_cmpeq_epi16(eb, zero);
      // Triangle kept when its three corners carry one enabled label (0 = not enabled).
      const __m256i t0_ad = _mm256_andnot_si256(za, _mm256_and_si256(ad, ab));
      const __m256i t1_ad = _mm256_andnot_si256(za, _mm256_and_si256(ac, ad));
      const __m256i t0_bc = _mm256_andnot_si256(za, _mm256_and_si256(ac, ab));
      const __m256i t1_bc = _mm256_andnot_si256(zb, _mm256_and_si256(bc, bd));
      const __m256i all4 = _mm256_and_si256(t0_ad, ac);
      const __m256i is_bc = _mm256_cmpeq_epi16(_mm256_and_si256(fb, diag), diag);
      const __m256i t0 = _mm256_blendv_epi8(t0_ad, t0_bc, is_bc);
      const __m256i t1 = _mm256_blendv_epi8(t1_ad, t1_bc, is_bc);
      const __m256i keep = _mm256_or_si256(
          diag, _mm256_or_si256(_mm256_and_si256(t0, one), _mm256_and_si256(t1, two)));
      const __m256i is_quad = _mm256_cmpeq_epi16(_mm256_and_si256(fb, quad), quad);
      fe[h] = _mm256_blendv_epi8(_mm256_and_si256(fb, keep), _mm256_and_si256(fb, all4), is_quad);
    }
    const __m256i idx = _mm256_permute4x64_epi64(_mm256_packus_epi16(fe[0], fe[1]), 0xD8);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + u), _mm256_shuffle_epi8(table, idx));
  }
}

// Vertex masks of row v from the cells above (prev) and below (cur); both readable and zero at
// index -1 and in [width - 1, width + kChunk). Non-zero masks go to mrow and their vertex
// indices (row_index + u) to `starts`, in increasing u.
RANGESEG_SIMD_AVX2_TARGET void vertex_masks_avx2(const std::uint8_t* prev, const std::uint8_t* cur,
                                                 int width, std::uint16_t* mrow,
                                                 std::int32_t row_index,
                                                 std::vector<std::int32_t>& starts) {
  const __m256i zero = _mm256_setzero_si256();
  alignas(32) std::uint8_t bytes[kChunk];
  for (int u = 0; u < width; u += kChunk) {
    const __m256i c11 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cur + u));
    const __m256i c01 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev + u));
    const __m256i c10 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cur + u - 1));
    const __m256i c00 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev + u - 1));
    const __m256i any = _mm256_or_si256(_mm256_or_si256(c11, c01), _mm256_or_si256(c10, c00));
    if (_mm256_testz_si256(any, any)) continue;
    // Inside a segment: every cell fully covered (sides only, no single-triangle diagonals).
    const __m256i full = _mm256_set1_epi8(kT | kB | kL | kR);
    const __m256i all_full = _mm256_and_si256(
        _mm256_and_si256(_mm256_cmpeq_epi8(c11, full), _mm256_cmpeq_epi8(c01, full)),
        _mm256_and_si256(_mm256_cmpeq_epi8(c10, full), _mm256_cmpeq_epi8(c00, full)));
    if (_mm256_movemask_epi8(all_full) == -1) continue;
    // vertex_mask() bit by bit, moving each input bit to its output position with 16-bit
    // shifts; the bits a shift carries in from the neighbouring byte are masked off.
    __m256i m = bit(_mm256_andnot_si256(c11, _mm256_srli_epi16(c01, 1)), 1);
    m = _mm256_or_si256(m, bit(_mm256_srli_epi16(c11, 3), 2));
    m = _mm256_or_si256(m, bit(_mm256_andnot_si256(_mm256_srli_epi16(c10, 1), c11), 4));
    m = _mm256_or_si256(m, bit(_mm256_srli_epi16(c10, 4), 8));
    m = _mm256_or_si256(
        m, bit(_mm256_andnot_si256(_mm256_slli_epi16(c00, 3), _mm256_slli_epi16(c10, 4)), 16));
    m = _mm256_or_si256(m, bit(c00, 32));
    m = _mm256_or_si256(
        m, bit(_mm256_andnot_si256(_mm256_slli_epi16(c01, 4), _mm256_slli_epi16(c00, 3)), 64));
    m = _mm256_or_si256(m, bit(_mm256_slli_epi16(c01, 1), 128));
    std::uint32_t nz =
        ~static_cast<std::uint32_t>(_mm256_movemask_epi8(_mm256_cmpeq_epi8(m, zero)));
    if (u + kChunk > width) nz &= (1u << (width - u)) - 1u;
    if (nz == 0) continue;
    _mm256_store_si256(reinterpret_cast<__m256i*>(bytes), m);
    do {
      const int i = __builtin_ctz(nz);
      mrow[u + i] = static_cast<std::uint16_t>(bytes[i] * 257u);
      starts.push_back(row_index + u + i);
      nz &= nz - 1;
    } while (nz != 0);
  }
}

RANGESEG_SIMD_AVX2_TARGET void masks_avx2(View<const std::int32_t> labels,
                                          View<const std::uint8_t> faces, const std::uint8_t* en,
                                          std::size_t n_labels, std::uint16_t* edges,
                                          std::ptrdiff_t stride, int v_begin, int v_end,
                                          std::vector<std::int32_t>& starts,
                                          BoundaryMaskScratch& scratch) {
  const int width = labels.width, height = labels.height;
  detail::resize_with_headroom(scratch.label_map, n_labels + 1);
  for (std::size_t l = 0; l < n_labels; ++l) {
    scratch.label_map[l] = en[l] ? static_cast<std::int32_t>(l) : 0;
  }
  scratch.label_map[n_labels] = 0;
  // Label rows with kChunk + 1 zeros after them; cell rows with a zero before and kChunk after.
  const std::size_t label_len = static_cast<std::size_t>(width) + kChunk + 16;
  const std::size_t side_len = static_cast<std::size_t>(width) + 2 * std::size_t{kChunk};
  detail::assign_with_headroom(scratch.labels16, 2 * label_len, 0);
  detail::assign_with_headroom(scratch.sides, 2 * side_len + kChunk, 0);
  std::uint16_t* e0 = scratch.labels16.data();
  std::uint16_t* e1 = e0 + label_len;
  std::uint8_t* prev = scratch.sides.data() + kChunk;
  std::uint8_t* cur = prev + side_len;
  const std::int32_t* map = scratch.label_map.data();
  const auto n = static_cast<std::uint32_t>(n_labels);
  enabled_labels_avx2(labels.row(v_begin), width, map, n, e0);
  if (v_begin > 0) {  // a band's first vertex row needs the cells above it
    enabled_labels_avx2(labels.row(v_begin - 1), width, map, n, e1);
    cell_sides_avx2(e1, e0, faces.row(v_begin - 1), width, prev);
  }
  for (int v = v_begin; v < v_end; ++v) {
    if (v + 1 < height) {
      enabled_labels_avx2(labels.row(v + 1), width, map, n, e1);
      cell_sides_avx2(e0, e1, faces.row(v), width, cur);
    } else {
      std::memset(cur, 0, static_cast<std::size_t>(width));
    }
    vertex_masks_avx2(prev, cur, width, edges + v * stride, static_cast<std::int32_t>(v * stride),
                      starts);
    std::swap(prev, cur);
    std::swap(e0, e1);
  }
}

#endif  // RANGESEG_SIMD_X86

}  // namespace

void find_boundary_vertices(View<const std::int32_t> labels, View<const std::uint8_t> faces, int s,
                            const std::uint8_t* enabled, std::size_t n_labels, std::uint16_t* edges,
                            std::ptrdiff_t stride, int v_begin, int v_end,
                            std::vector<std::int32_t>& starts, BoundaryMaskScratch& scratch) {
  starts.clear();
  v_begin = std::max(v_begin, 0);
  v_end = std::min(v_end, labels.height);
  if (labels.width <= 0 || v_begin >= v_end) return;
  assert(v_begin % s == 0);
#if RANGESEG_SIMD_X86
  if (s == 1 && n_labels <= 65536 && detail::simd::chosen_isa() >= detail::simd::Isa::avx2) {
    masks_avx2(labels, faces, enabled, n_labels, edges, stride, v_begin, v_end, starts, scratch);
    return;
  }
#endif
  masks_scalar(labels, faces, s, enabled, n_labels, edges, stride, v_begin, v_end, starts, scratch);
}

}  // namespace rangeseg::polygons_detail
