// pgs_kernel.h: the HLS kernel's top function and its build-time parameters (hls_export/README.md).
//
// Parameters (-D on the compiler or Vitis HLS cflags), as the RTL kernel's (rtl/README.md):
//   PGS_MAX_BODIES     body table depth (65536; a power of two: a record's body index is used modulo it)
//   PGS_MAX_MANIFOLDS  impulse table depth = manifolds per pass (262144)
//   PGS_CONS_W, PGS_BODY_IN_W, PGS_BODY_OUT_W  stream beat widths (512, 128, 128; pgs_stream.h)
//   PGS_IINV_W         inverse-inertia words per body (3; 1 scalar, 6 the symmetric 3x3; pgs_stream.h)
//   PGS_MU_W           friction-coefficient words per friction record (0 the constant 0.7; 1 a word; pgs_stream.h)
//   PGS_IMPULSES_IN_RECORDS  1: the impulses travel with the records, out on m_axis_imp; 0: on chip (pgs_stream.h)
//   PGS_TANGENTS_ON_CHIP  1: friction records without t0, t1, derived from n in the format (the RTL's
//                      TANGENTS_ON_CHIP; only with PGS_IMPULSES_IN_RECORDS = 1, PGS_IINV_W = 3, PGS_MU_W = 0)
//   PGS_SOFT_CONTACT   1: Box2D's soft contact row (the RTL's SOFT_CONTACT): lam * keep before the add, with the
//                      options bit kOptSoftContact and the arguments keep_dyn, keep_static; 0: the rigid row only
//   PGS_WINDOW         > 0: the window kernel (the RTL's WINDOW with IMPULSES_IN_RECORDS = 1; a power of two): each
//                      fetch of the records serves up to PGS_WINDOW_CTX (8) passes of one kind over a ring of that
//                      many records of PGS_LANES (1, 2 or 4) slots, the arguments lag and fetch_passes; 0: streaming
//   PGS_SHARED_DATAPATH  1 (the default): a contact and a friction manifold-pass run on one datapath, the RTL's
//                      SHARED_DATAPATH (generated/pgs_shared_datapath.h: each operator once, its operands chosen by
//                      the record's kind); 0: each kind's own arithmetic (pgs_solver.h solve_contact, solve_friction)
//   PGS_EXP_BITS, PGS_MAN_BITS  the number format (8, 23: binary32; C simulation also 5, 10 and 8, 7; pgs_fp.h)
#ifndef PGS_KERNEL_H
#define PGS_KERNEL_H

#include <cstdint>

#include "generated/pgs_regs.h"
#include "pgs_stream.h"

#ifndef PGS_MAX_BODIES
#define PGS_MAX_BODIES 65536
#endif
#ifndef PGS_MAX_MANIFOLDS
#define PGS_MAX_MANIFOLDS 262144
#endif
#ifndef PGS_SOFT_CONTACT
#define PGS_SOFT_CONTACT 0
#endif
#ifndef PGS_SHARED_DATAPATH
#define PGS_SHARED_DATAPATH 1
#endif

namespace pgs {

constexpr uint32_t kMaxBodies = PGS_MAX_BODIES;
constexpr uint32_t kMaxManifolds = PGS_MAX_MANIFOLDS;
static_assert((kMaxBodies & (kMaxBodies - 1)) == 0, "PGS_MAX_BODIES must be a power of two");
static_assert(PGS_WINDOW == 0 || PGS_SOFT_CONTACT == 0,
              "the soft contact row is a configuration of the streaming kernel (PGS_WINDOW = 0), as the RTL's");

// The s_axi_control offsets (kReg*, pinned with offset= in the INTERFACE pragmas: the Vitis HLS defaults for
// this argument order), kMaxIterations, the options bits (kOptInterleaved: interleaved pass order) and the
// error codes (kErr*) are in generated/pgs_regs.h, from models/kernel/register_map.py.

// Pass p of a step: friction or contact, and its iteration (models.golden.contact_solver.pass_sequence).
inline bool pass_is_friction(uint32_t p, uint32_t iterations, bool interleaved) {
    return interleaved ? (p & 1u) != 0 : p >= iterations;
}
inline uint32_t pass_iteration(uint32_t p, uint32_t iterations, bool interleaved) {
    return interleaved ? p >> 1 : (p >= iterations ? p - iterations : p);
}

}  // namespace pgs

// the impulse-out stream, an argument of the build whose impulses travel with the records only
#if PGS_IMPULSES_IN_RECORDS
#define PGS_IMP_OUT_PORT hls::stream<pgs::imp_beat_t>& m_axis_imp,
#else
#define PGS_IMP_OUT_PORT
#endif
// the soft contact row's keep factors (format bit patterns), arguments of the soft contact build only
#if PGS_SOFT_CONTACT
#define PGS_SOFT_PORTS uint32_t keep_dyn, uint32_t keep_static,
#else
#define PGS_SOFT_PORTS
#endif

// the window kernel's arguments (the RTL's lag and fetch_passes registers), of the window build only
#if PGS_WINDOW
#define PGS_WINDOW_PORTS uint32_t lag, uint32_t fetch_passes,
#else
#define PGS_WINDOW_PORTS
#endif

void pgs_kernel(hls::stream<pgs::body_in_beat_t>& s_axis_body, hls::stream<pgs::cons_beat_t>& s_axis_cons,
                hls::stream<pgs::body_out_beat_t>& m_axis_body, hls::stream<pgs::trace_t>& trace,
                PGS_IMP_OUT_PORT uint32_t num_bodies, uint32_t num_manifolds, uint32_t iterations, uint32_t dt,
                uint32_t gravity_x, uint32_t gravity_y, uint32_t gravity_z, uint32_t damping, uint32_t options,
                PGS_SOFT_PORTS PGS_WINDOW_PORTS uint32_t* status, uint32_t* issued);

#endif  // PGS_KERNEL_H
