// GDAL's terminal progress printer (dsmplan/raster_io.hpp), so that the command line prints the
// progress GDAL users know without including GDAL itself.
#include <cpl_progress.h>

#include "dsmplan/raster_io.hpp"

namespace dsmplan {

bool print_terminal_progress(double fraction) { return GDALTermProgress(fraction, nullptr, nullptr) != 0; }

}  // namespace dsmplan
