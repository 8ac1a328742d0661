// libFuzzer target: classify (engine/classify.h, paper 3.1, 3.2, App. B, C) on raw polygons.
// The bytes decode into a small polygon: byte 0 = vertex count n (3..kMaxVertices after clamping) and
// whether rotation indices are prescribed (bit 7); then per vertex two coordinates, each either a small
// grid value (one byte: exact collinearities and repeated points, the hard cases of the exact predicates) or
// a raw double (8 bytes: NaN, inf, denormals), chosen by a flag byte; then, when prescribed, one byte per
// vertex as R_i (may be out of range: validate_polygon must refuse it). validate_polygon, then classify with
// a deadline so that a hard case cannot hang the fuzzer. InputError and Cancelled (the deadline) are expected
// answers; anything else escapes.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/classify.h"
#include "engine/error.h"

namespace {

constexpr std::size_t kMaxVertices = 48;  // classify's table is O(n^3): keep an input well under a second

class Reader {
public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  double coordinate(bool raw) {
    if (!raw) return (static_cast<int>(byte()) - 128) / 8.0;  // a grid of step 1/8 in [-16, 16)
    std::uint8_t bytes[8] = {};
    for (std::uint8_t& b : bytes) b = byte();
    double value;
    std::memcpy(&value, bytes, sizeof value);
    return value;
  }

private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Reader in(data, size);
  const std::uint8_t head = in.byte();
  const std::size_t n = head & 0x7f;
  if (n > kMaxVertices) return 0;
  const bool prescribed = (head & 0x80) != 0;

  lipmap::BoundaryPolygon polygon;
  for (std::size_t i = 0; i < n && !in.empty(); ++i) {
    const std::uint8_t flags = in.byte();
    const double x = in.coordinate(flags & 1);
    const double y = in.coordinate(flags & 2);
    polygon.vertices.push_back({x, y});
  }
  if (prescribed) {
    std::vector<int> rotation;
    // Read as many as there are bytes (up to n + 1): a wrong length is one of validate's cases.
    for (std::size_t i = 0; i <= n && !in.empty(); ++i) rotation.push_back(static_cast<int>(in.byte()) % 9 - 1);
    polygon.rotation_indices = std::move(rotation);
  }

  try {
    lipmap::validate_polygon(polygon);
    lipmap::CancelToken deadline;
    deadline.set_deadline(lipmap::CancelToken::Clock::now() + std::chrono::seconds(2));
    (void)lipmap::classify(polygon, &deadline);
  } catch (const lipmap::InputError&) {
  } catch (const lipmap::Cancelled&) {
  }
  return 0;
}
