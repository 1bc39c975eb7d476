// dsmplan/rpc_io.hpp: the files satellite cameras come in (an OSSIM `.geom` beside the image,
// GDAL's RPC domain: TIFF tags, `_RPC.TXT`, `.RPB`, DIMAP), read into the RpcModel and RpcCamera
// of rpc.hpp. GDAL does the reading, so these live in the GDAL layer (src/geo/rpc_reader.cpp).
#pragma once

#include <array>
#include <string>

#include "dsmplan/rpc.hpp"

namespace dsmplan {

/// Reads an OSSIM keyword list (`key: value` lines, as OTB, CARS and shareloc write `.geom`
/// files: type ossimRpcModel, polynomial_format B, line_num_coeff_00 .. samp_den_coeff_19, the
/// ten offsets and scales). InputError naming the file and the key for a missing, repeated or
/// non-numeric coefficient, a zero scale, a polynomial_format other than B.
RpcModel read_ossim_geom(const std::string& path);

/// Reads the RPC of a raster from GDAL's RPC metadata domain (TIFF RPC tags, a `_RPC.TXT` or
/// `.RPB` beside it, NITF RPC00B, DIMAP ...). InputError "has no RPC" when GDAL finds none.
RpcModel read_gdal_rpc(const std::string& raster_path);

/// The sensor offset {col, row} of a Pléiades crop within its scene for a one-based `.geom` RPC,
/// from its GeoTIFF transform (a pure shift: scale 1, no rotation, no CRS; see read_rpc_camera).
/// Returns {0, 0} for an image without a transform. InputError for a transform that is not a
/// shift by a whole or half pixel.
std::array<double, 2> read_sensor_offset(const std::string& raster_path);

/// Whether the image has an RPC: a `.geom` beside it or GDAL's RPC domain not empty (no check
/// of the numbers; read_rpc_camera does that).
bool has_rpc(const std::string& raster_path);

/// The camera of an image: its RPC from a `.geom` beside it (IMG.geom for IMG.tif) when there is
/// one, else from GDAL's RPC domain; and its sensor offset.
///
/// Sensor offset. An RPC read by GDAL from the image itself is already the image's own (GDAL and
/// the tools that write RPC tags shift LINE_OFF/SAMP_OFF when they crop, and GDAL makes Pléiades'
/// one-based RPCs zero-based when it reads DIMAP): offset 0. A `.geom` is the scene's RPC as
/// Airbus delivers it for Pléiades: one-based (the centre of the scene's first pixel at sample 1,
/// as GDAL's reader_pleiades.cpp, s2p and ASP document), and the crop says where it lies in the
/// scene by its GeoTIFF transform (a shift, no CRS). Two writers are found in the data
/// (data/pleiades-kahramanmaras), for a crop starting at the scene's 0-based pixel k:
///   - Airbus's (XPAND; origins 12114.5 5511.5, 12098.5 5108.5, 12978.5 6897.5): the transform
///     gives the RPC's own position, origin k + 1 - 0.5 = k + 0.5: sensor offset = origin + 0.5;
///   - GDAL's (post_event_img2, origin 12815 7219): the transform gives GDAL's position in the
///     scene, origin k: sensor offset = k + 1 = origin + 1 (the RPC being one-based).
/// A crop is cut on the pixel grid, so the fraction of the origin tells them apart (.5 or .0);
/// any other fraction is an InputError (a resampled image, not a crop).
/// Proof (tests/rpc_test.cpp, RpcSensorOffset): tie points found by correlation in the two
/// images of each pair lie on the RPC epipolar curve, median distance across it 0.10 px
/// (pre-event, both Airbus's) and -0.05 px (post-event, one of each writer), while reading the
/// GDAL-written crop's offset half a pixel or a pixel otherwise puts them 0.56 to 1.26 px off.
/// What the pairs cannot show is a shift common to both images of a pair (it moves the ground by
/// about half a metre, and there is no ground truth): that the .geom keeps Airbus's one-based
/// offsets rests on the Pléiades convention above.
RpcCamera read_rpc_camera(const std::string& raster_path);

}  // namespace dsmplan
