// fp_unpack: split a binary floating-point word into fields and classify it (combinational).
//
// Format: 1 sign bit, EXP_BITS exponent bits, MAN_BITS stored mantissa bits (binary32 = (8, 23),
// binary16 = (5, 10), bfloat16 = (8, 7)).
// Exceptions: subnormal inputs are flushed (read as a zero with their sign kept), so `is_zero` is
// set for +-0 and every +-subnormal, and then `exp` and `sig` are 0. `is_inf` / `is_nan` decode the
// all-ones exponent. For finite non-zero inputs `sig` carries the hidden bit.
// Latency: 0 (combinational).
`default_nettype none

module fp_unpack #(
    parameter int EXP_BITS = 8,
    parameter int MAN_BITS = 23
) (
    input  wire logic [EXP_BITS+MAN_BITS:0] x,
    output logic                            sign,
    output logic [EXP_BITS-1:0]             exp,      // biased exponent; 0 for (flushed) zeros
    output logic [MAN_BITS:0]               sig,      // {hidden bit, mantissa}; 0 for zeros
    output logic                            is_zero,  // +-0 or +-subnormal (flush to zero)
    output logic                            is_inf,
    output logic                            is_nan
);
    logic [EXP_BITS-1:0] e_raw;
    logic [MAN_BITS-1:0] m_raw;
    logic                e_zero, e_ones;

    always_comb begin
        sign    = x[EXP_BITS+MAN_BITS];
        e_raw   = x[EXP_BITS+MAN_BITS-1:MAN_BITS];
        m_raw   = x[MAN_BITS-1:0];
        e_zero  = (e_raw == '0);
        e_ones  = (e_raw == '1);
        is_zero = e_zero;
        is_inf  = e_ones && (m_raw == '0);
        is_nan  = e_ones && (m_raw != '0);
        exp     = e_raw;
        sig     = e_zero ? '0 : {1'b1, m_raw};
    end
endmodule

`default_nettype wire
