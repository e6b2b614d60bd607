#include "vision/human_types.hpp"
