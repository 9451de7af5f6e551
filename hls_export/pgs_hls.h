// pgs_hls.h: the Vitis HLS headers the kernel needs (ap_uint, hls::stream, ap_axiu), or the local shims in
// hls_export/shims/ when the real headers are not on the include path (plain g++ C simulation).
// -DPGS_FORCE_SHIMS uses the shims even where Vitis is installed.
#ifndef PGS_HLS_H
#define PGS_HLS_H

#if !defined(PGS_FORCE_SHIMS) && __has_include(<ap_int.h>) && __has_include(<hls_stream.h>) && \
    __has_include(<ap_axi_sdata.h>)
#include <ap_axi_sdata.h>
#include <ap_int.h>
#include <hls_stream.h>
#define PGS_USING_SHIMS 0
#else
#include "shims/ap_axi_sdata.h"
#include "shims/ap_int.h"
#include "shims/hls_stream.h"
#define PGS_USING_SHIMS 1
#endif

#endif  // PGS_HLS_H
