// pgs_kernel.h: the HLS kernel's top function and its build-time parameters (hls_export/README.md).
//
// Parameters (-D on the compiler or Vitis HLS cflags), as the RTL kernel's (rtl/README.md):
//   PGS_MAX_BODIES     body table depth (65536; a power of two: a record's body index is used modulo it)
//   PGS_MAX_MANIFOLDS  impulse table depth = manifolds per pass (262144)
//   PGS_CONS_W, PGS_BODY_IN_W, PGS_BODY_OUT_W  stream beat widths (512, 128, 128; pgs_stream.h)
#ifndef PGS_KERNEL_H
#define PGS_KERNEL_H

#include <cstdint>

#include "pgs_stream.h"

#ifndef PGS_MAX_BODIES
#define PGS_MAX_BODIES 65536
#endif
#ifndef PGS_MAX_MANIFOLDS
#define PGS_MAX_MANIFOLDS 262144
#endif

namespace pgs {

constexpr uint32_t kMaxBodies = PGS_MAX_BODIES;
constexpr uint32_t kMaxManifolds = PGS_MAX_MANIFOLDS;
constexpr uint32_t kMaxIterations = 65535;
static_assert((kMaxBodies & (kMaxBodies - 1)) == 0, "PGS_MAX_BODIES must be a power of two");

// s_axi_control offsets of the arguments (rtl/README.md register map; the Vitis HLS defaults for this
// argument order, pinned with offset= in the INTERFACE pragmas)
constexpr uint32_t kRegNumBodies = 0x10, kRegNumManifolds = 0x18, kRegIterations = 0x20, kRegDt = 0x28,
                   kRegGravityX = 0x30, kRegGravityY = 0x38, kRegGravityZ = 0x40, kRegDamping = 0x48,
                   kRegOptions = 0x50, kRegStatus = 0x58, kRegIssued = 0x78;

// error codes of the status register (flag bit = code - 1; bits 15:8 = the first code of the run)
constexpr uint32_t kErrConsTlast = 1, kErrBodyTlast = 2, kErrBadArgs = 3, kErrBodyIndex = 4;

// options bit 0: interleaved pass order (contact, friction per iteration)
constexpr uint32_t kOptInterleaved = 1;

// Pass p of a step: friction or contact, and its iteration (models.contact_solver.pass_sequence).
inline bool pass_is_friction(uint32_t p, uint32_t iterations, bool interleaved) {
    return interleaved ? (p & 1u) != 0 : p >= iterations;
}
inline uint32_t pass_iteration(uint32_t p, uint32_t iterations, bool interleaved) {
    return interleaved ? p >> 1 : (p >= iterations ? p - iterations : p);
}

}  // namespace pgs

void pgs_kernel(hls::stream<pgs::body_in_beat_t>& s_axis_body, hls::stream<pgs::cons_beat_t>& s_axis_cons,
                hls::stream<pgs::body_out_beat_t>& m_axis_body, hls::stream<pgs::trace_t>& trace,
                uint32_t num_bodies, uint32_t num_manifolds, uint32_t iterations, uint32_t dt, uint32_t gravity_x,
                uint32_t gravity_y, uint32_t gravity_z, uint32_t damping, uint32_t options, uint32_t* status,
                uint32_t* issued);

#endif  // PGS_KERNEL_H
