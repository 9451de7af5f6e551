// ap_axi_sdata.h (shim): ap_axiu<D, U, TI, TD>, the AXI4-Stream beat of Vitis HLS, for C simulation with
// g++ where the Vitis headers are absent (hls_export/pgs_hls.h includes it only then). Same members as
// the real one (data, keep, strb, user, last, id, dest); a side channel of width 0 is held in one bit.
#ifndef PGS_SHIM_AP_AXI_SDATA_H
#define PGS_SHIM_AP_AXI_SDATA_H

#include "ap_int.h"

template <int D, int U, int TI, int TD>
struct ap_axiu {
    ap_uint<D> data;
    ap_uint<(D + 7) / 8> keep;
    ap_uint<(D + 7) / 8> strb;
    ap_uint<(U > 0 ? U : 1)> user;
    ap_uint<1> last;
    ap_uint<(TI > 0 ? TI : 1)> id;
    ap_uint<(TD > 0 ? TD : 1)> dest;
};

#endif  // PGS_SHIM_AP_AXI_SDATA_H
