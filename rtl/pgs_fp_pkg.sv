// pgs_fp_pkg: elaboration-time helpers of the generated kernel datapaths (rtl/gen).
//
// * fp_const / fp_from_real: a float64 value (bit pattern, or a `real`) rounded to the format with
//   EXP_BITS exponent and MAN_BITS mantissa bits exactly as models/formats/number_format.py
//   NumberFormat.round does: round to nearest, ties to even, with an unbounded exponent; a rounded
//   magnitude below the smallest normal becomes a signed zero (flush after rounding); overflow gives
//   +-inf; NaN gives the canonical quiet NaN. The result is in the low 1+EXP_BITS+MAN_BITS bits.
//   Meant for localparams (constant functions evaluated at elaboration). Valid for
//   2 <= EXP_BITS <= 10 and 1 <= MAN_BITS <= 24, like the golden model.
// * tmax: the larger of two ints (the generated pipelines compute their schedule in localparams).
`default_nettype none

package pgs_fp_pkg;

    function automatic logic [63:0] fp_const(input logic [63:0] f64, input int exp_bits, input int man_bits);
        logic        sign;
        logic [62:0] mag;
        logic [62:0] mag_r;
        logic [62:0] low_mask;
        logic [62:0] half_minus_one;
        logic [62:0] lsb;
        int          shift;
        int          bias;
        int          e_unb;
        logic [63:0] exp_field;
        logic [63:0] man_field;
        sign           = f64[63];
        mag            = f64[62:0];
        shift          = 52 - man_bits;
        bias           = (1 << (exp_bits - 1)) - 1;
        if (mag[62:52] == 11'h7FF) begin
            if (mag[51:0] != 52'd0) begin   // NaN -> canonical quiet NaN
                return (64'((1 << exp_bits) - 1) << man_bits) | (64'd1 << (man_bits - 1));
            end
            return (64'(sign) << (exp_bits + man_bits)) | (64'((1 << exp_bits) - 1) << man_bits);
        end
        low_mask       = (63'd1 << shift) - 63'd1;
        half_minus_one = (63'd1 << (shift - 1)) - 63'd1;
        lsb            = (mag >> shift) & 63'd1;
        mag_r          = (mag + half_minus_one + lsb) & ~low_mask;
        e_unb          = int'(mag_r[62:52]) - 1023;
        if (e_unb < 1 - bias) begin         // below the smallest normal (also float64 zeros/subnormals)
            return 64'(sign) << (exp_bits + man_bits);
        end
        if (e_unb > bias) begin             // overflow
            return (64'(sign) << (exp_bits + man_bits)) | (64'((1 << exp_bits) - 1) << man_bits);
        end
        exp_field = 64'(e_unb + bias);
        man_field = 64'(mag_r[51:0] >> shift);
        return (64'(sign) << (exp_bits + man_bits)) | (exp_field << man_bits) | man_field;
    endfunction

    function automatic logic [63:0] fp_from_real(input real value, input int exp_bits, input int man_bits);
        return fp_const($realtobits(value), exp_bits, man_bits);
    endfunction

    function automatic int tmax(input int a, input int b);
        return (a > b) ? a : b;
    endfunction

endpackage

`default_nettype wire
