// GDAL's RPC transformer for one of dsmplan's RPC models: the same numbers, GDAL's evaluation
// (gdal_rpc.cpp). The independent oracle of RpcCamera::project() in tests/rpc_test.cpp and its
// peer in bench/bench_rpc.cpp. No elevation model: heights are given with each point.
#pragma once

#include <gdal_alg.h>

#include "dsmplan/rpc.hpp"

/// The model as GDAL's RPC record (its validity box: the whole globe).
inline GDALRPCInfoV2 gdal_rpc_info(const dsmplan::RpcModel& m) {
  GDALRPCInfoV2 info{};
  info.dfLINE_OFF = m.line_off, info.dfSAMP_OFF = m.samp_off, info.dfLAT_OFF = m.lat_off;
  info.dfLONG_OFF = m.long_off, info.dfHEIGHT_OFF = m.height_off;
  info.dfLINE_SCALE = m.line_scale, info.dfSAMP_SCALE = m.samp_scale, info.dfLAT_SCALE = m.lat_scale;
  info.dfLONG_SCALE = m.long_scale, info.dfHEIGHT_SCALE = m.height_scale;
  for (int i = 0; i < 20; ++i) {
    info.adfLINE_NUM_COEFF[i] = m.line_num[i], info.adfLINE_DEN_COEFF[i] = m.line_den[i];
    info.adfSAMP_NUM_COEFF[i] = m.samp_num[i], info.adfSAMP_DEN_COEFF[i] = m.samp_den[i];
  }
  info.dfMIN_LONG = -180, info.dfMIN_LAT = -90, info.dfMAX_LONG = 180, info.dfMAX_LAT = 90;
  info.dfERR_BIAS = info.dfERR_RAND = -1;
  return info;
}

inline void* gdal_rpc_transformer(const dsmplan::RpcModel& m) {
  GDALRPCInfoV2 info = gdal_rpc_info(m);
  return GDALCreateRPCTransformerV2(&info, FALSE, 0.0, nullptr);
}
