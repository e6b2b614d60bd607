#include "vision/segmentation_types.hpp"

namespace sg {

const char* toString(GroundSource source) {
  switch (source) {
    case GroundSource::kHough: return "hough";
    case GroundSource::kPrior: return "prior";
    case GroundSource::kPrevious: return "previous";
    case GroundSource::kNone: return "none";
  }
  return "none";
}

}  // namespace sg
