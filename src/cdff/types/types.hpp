#pragma once
// All CDFF core data types (without the OpenCV and PCL conversions).
#include "cdff/types/buffer.hpp"
#include "cdff/types/contours.hpp"
#include "cdff/types/features.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/image.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/polygon_model.hpp"
#include "cdff/types/sensors.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"
#include "cdff/types/track_state.hpp"
