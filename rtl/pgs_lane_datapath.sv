// pgs_lane_datapath: the datapath of one issue lane, a contact or a friction record a cycle (rtl/gen, rtl/generated).
//
// SHARED_DATAPATH = 1: one generated datapath for both passes (pgs_shared_pipe of the lane's options: rtl/gen/
// shared_datapath.py binds the friction pass onto the contact pass's operators); the record's kind travels with it
// and both kinds take its LATENCY (the contact pipe's), so records of either kind may follow each other in any
// cycle and retire in issue order. SHARED_DATAPATH = 0: a contact pipe and a friction pipe side by side, a record
// entering the pipe of its kind; each has its own latency, so the issue must not let a record of the other kind
// overtake (the streaming kernel drains the pipe at a switch: pgs_seq_hazards), or with ALIGN the friction results
// wait for the contact pipe's latency (the window kernel's records of either kind follow each other back to back).
// Both forms compute the same words (the golden model's, bit for bit).
//
// Inputs (valid with in_valid): in_kind (0 contact, 1 friction), in_tag, in_rec the kind's record words after the
// header (a contact record's 23; a friction record's 14, 8 without the tangents, then with MU_W its coefficient),
// in_lam / in_lamT the impulses the pass starts from (a friction pass's lam: its friction limit), the bodies' words:
// xA, xB, v and w of A and B, the inverse masses and inertias (0 where the caller freezes a body), in_spin_damp (a
// friction record's), and with SOFT_CONTACT in_soft and the two keep factors. Outputs: out_valid, out_kind, out_tag
// and out_imp (contact: lam[0..3]; friction: lamT[0..1], then two zero words), out_vel (vA, wA, vB, wB); ev_* the
// floating-point events the datapath raised in the previous cycle (pgs_run_counters sums them).
// Latency: pgs_pipe_latency_pkg::shared_latency(MAN_BITS) cycles for either kind (the contact pipe's); the two-pipe
// form: contact_latency, friction_latency (friction_pipe_tb_latency with TANGENTS_ON_CHIP), with ALIGN both the
// contact pipe's.
`default_nettype none

module pgs_lane_datapath #(
    parameter int EXP_BITS         = 8,
    parameter int MAN_BITS         = 23,
    parameter int TAG_W            = 64,
    parameter int IINV_W           = 3,
    parameter int MU_W             = 0,
    parameter bit TANGENTS_ON_CHIP = 1'b0,
    parameter bit SOFT_CONTACT     = 1'b0,
    parameter bit SHARED_DATAPATH  = 1'b1,
    parameter bit ALIGN            = 1'b0,   // two pipes: the friction results wait for the contact pipe's latency
    parameter int DELAY_BLOCK_MIN_DEPTH = 0,
    parameter bit ADD_SHIFT_DSP    = 1'b0,   // every fp_add of the pipes in its DSP48E2 form (fp_add's SHIFT_DSP)
    localparam int W               = 1 + EXP_BITS + MAN_BITS,
    localparam int REC_WORDS       = 23,     // the words of in_rec (a contact record's)
    localparam int EV_W            = 16
) (
    input  wire logic                   clk,
    input  wire logic                   rst,
    input  wire logic                   in_valid,
    input  wire logic                   in_kind,
    input  wire logic [TAG_W-1:0]       in_tag,
    input  wire logic [REC_WORDS*W-1:0] in_rec,
    input  wire logic [4*W-1:0]         in_lam,
    input  wire logic [2*W-1:0]         in_lamT,
    input  wire logic [3*W-1:0]         in_xa,
    input  wire logic [3*W-1:0]         in_xb,
    input  wire logic [6*W-1:0]         in_vwa,      // vA, wA
    input  wire logic [6*W-1:0]         in_vwb,      // vB, wB
    input  wire logic [W-1:0]           in_ma,
    input  wire logic [W-1:0]           in_mb,
    input  wire logic [IINV_W*W-1:0]    in_ia,
    input  wire logic [IINV_W*W-1:0]    in_ib,
    input  wire logic                   in_spin_damp,
    input  wire logic                   in_soft,
    input  wire logic [W-1:0]           in_keep_dyn,
    input  wire logic [W-1:0]           in_keep_static,
    output logic                        out_valid,
    output logic                        out_kind,
    output logic      [TAG_W-1:0]       out_tag,
    output logic      [4*W-1:0]         out_imp,
    output logic      [12*W-1:0]        out_vel,
    output logic      [EV_W-1:0]        ev_overflow,
    output logic      [EV_W-1:0]        ev_underflow,
    output logic      [EV_W-1:0]        ev_invalid
);
    localparam int F_PIPE     = pgs_stream_layout_pkg::friction_pipe_words(MU_W, TANGENTS_ON_CHIP);
    localparam int SOFT_WORDS = SOFT_CONTACT ? 2 : 0;
    localparam int BODY_WORDS = 20 + 2 * IINV_W;   // xA, xB, vA wA vB wB, mInvA, mInvB, IInvA, IInvB
    logic [BODY_WORDS*W-1:0] bodies;
    assign bodies = {in_ib, in_ia, in_mb, in_ma, in_vwb, in_vwa, in_xb, in_xa};

    if (IINV_W != 1 && IINV_W != 3 && IINV_W != 6) begin : g_bad_iinv
        $error("pgs_lane_datapath: IINV_W must be 1, 3 or 6");
    end
    if ((TANGENTS_ON_CHIP || SOFT_CONTACT) && IINV_W != 3) begin : g_bad_mode
        $error("pgs_lane_datapath: the soft contact and the tangents derived on chip are built for IINV_W = 3");
    end
    if (TANGENTS_ON_CHIP && MU_W != 0) begin : g_bad_tangents
        $error("pgs_lane_datapath: the tangents derived on chip are built for the constant friction coefficient");
    end

    if (SHARED_DATAPATH) begin : g_shared
        // the shared layout (rtl/gen/kernel_graphs.py shared_in): the record's 23 words, lam[4], lamT[2], the bodies'
        // words, the soft contact's keep factors
        localparam int N_IN = REC_WORDS + 6 + BODY_WORDS + SOFT_WORDS;
        logic [N_IN*W-1:0] s_in;
        logic [16*W-1:0]   s_out;
        if (SOFT_CONTACT) begin : g_keep
            assign s_in = {in_keep_static, in_keep_dyn, bodies, in_lamT, in_lam, in_rec};
        end else begin : g_rigid
            assign s_in = {bodies, in_lamT, in_lam, in_rec};
            wire unused_soft = ^{in_soft, in_keep_dyn, in_keep_static};
        end
        // one module per option set (the same ports but in_soft, the same latency)
        `define PGS_SHARED_PIPE(name) \
            name #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(TAG_W), \
                   .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_pipe ( \
                .clk, .rst, .in_valid, .in_kind, .in_tag, .in_data(s_in), .in_spin_damp, .in_count(1'b1), \
                .out_valid, .out_kind, .out_tag, .out_data(s_out), .ev_overflow, .ev_underflow, .ev_invalid);
        `define PGS_SHARED_SOFT_PIPE(name) \
            name #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(TAG_W), \
                   .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_pipe ( \
                .clk, .rst, .in_valid, .in_kind, .in_tag, .in_data(s_in), .in_spin_damp, .in_soft, \
                .in_count(1'b1), .out_valid, .out_kind, .out_tag, .out_data(s_out), .ev_overflow, .ev_underflow, \
                .ev_invalid);
        if (IINV_W == 1 && MU_W == 1) begin : g_scalar_mu
            `PGS_SHARED_PIPE(pgs_shared_pipe_scalar_mu)
        end else if (IINV_W == 1) begin : g_scalar
            `PGS_SHARED_PIPE(pgs_shared_pipe_scalar)
        end else if (IINV_W == 6 && MU_W == 1) begin : g_full_mu
            `PGS_SHARED_PIPE(pgs_shared_pipe_full_mu)
        end else if (IINV_W == 6) begin : g_full
            `PGS_SHARED_PIPE(pgs_shared_pipe_full)
        end else if (SOFT_CONTACT && TANGENTS_ON_CHIP) begin : g_soft_tb
            `PGS_SHARED_SOFT_PIPE(pgs_shared_pipe_soft_tb)
        end else if (SOFT_CONTACT && MU_W == 1) begin : g_mu_soft
            `PGS_SHARED_SOFT_PIPE(pgs_shared_pipe_mu_soft)
        end else if (SOFT_CONTACT) begin : g_soft
            `PGS_SHARED_SOFT_PIPE(pgs_shared_pipe_soft)
        end else if (TANGENTS_ON_CHIP) begin : g_tb
            `PGS_SHARED_PIPE(pgs_shared_pipe_tb)
        end else if (MU_W == 1) begin : g_mu
            `PGS_SHARED_PIPE(pgs_shared_pipe_mu)
        end else begin : g_default
            `PGS_SHARED_PIPE(pgs_shared_pipe)
        end
        `undef PGS_SHARED_PIPE
        `undef PGS_SHARED_SOFT_PIPE
        assign out_imp = s_out[0 +: 4*W];
        assign out_vel = s_out[4*W +: 12*W];
    end else begin : g_two_pipes
        localparam int C_LAT = pgs_pipe_latency_pkg::contact_latency(MAN_BITS);
        localparam int F_LAT = TANGENTS_ON_CHIP ? pgs_pipe_latency_pkg::friction_pipe_tb_latency(MAN_BITS)
                                                : pgs_pipe_latency_pkg::friction_latency(MAN_BITS);
        localparam int F_ALIGN = ALIGN ? C_LAT - F_LAT : 0;
        if (F_ALIGN < 0) begin : g_bad_align
            $error("pgs_lane_datapath: aligning the pipes needs the friction pipe no deeper than the contact pipe");
        end
        logic              c_valid, f_valid, f_pipe_valid;
        logic [TAG_W-1:0]  c_tag, f_tag, f_pipe_tag;
        logic [16*W-1:0]   c_out;
        logic [14*W-1:0]   f_out, f_pipe;
        logic [EV_W-1:0]   c_ev_ovf, c_ev_unf, c_ev_inv, f_ev_ovf, f_ev_unf, f_ev_inv;
        // the contact pipe's inputs: its 23 record words, lam[4], the bodies' words, the soft keep factors; the
        // friction pipe's: its F_PIPE record words, lam[4], lamT[2], the bodies' words, then (MU_W = 1) the coefficient
        logic [(27 + BODY_WORDS + SOFT_WORDS)*W-1:0] c_in;
        logic [(F_PIPE + 6 + BODY_WORDS + MU_W)*W-1:0] f_in;
        if (SOFT_CONTACT) begin : g_keep
            assign c_in = {in_keep_static, in_keep_dyn, bodies, in_lam, in_rec};
        end else begin : g_rigid
            assign c_in = {bodies, in_lam, in_rec};
        end
        if (MU_W == 1) begin : g_mu_word
            assign f_in = {in_rec[F_PIPE*W +: W], bodies, in_lamT, in_lam, in_rec[0 +: F_PIPE*W]};
        end else begin : g_mu_const
            assign f_in = {bodies, in_lamT, in_lam, in_rec[0 +: F_PIPE*W]};
        end
        wire c_in_valid = in_valid && !in_kind;
        wire f_in_valid = in_valid && in_kind;
        `define PGS_PIPE(name, inst, valid, data, vo, to, o, e1, e2, e3) \
            name #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(TAG_W), \
                   .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) inst ( \
                .clk, .rst, .in_valid(valid), .in_tag, .in_data(data), .in_count(1'b1), .out_valid(vo), \
                .out_tag(to), .out_data(o), .ev_overflow(e1), .ev_underflow(e2), .ev_invalid(e3));
        `define PGS_FRICTION_PIPE(name) \
            name #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(TAG_W), \
                   .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_friction ( \
                .clk, .rst, .in_valid(f_in_valid), .in_tag, .in_data(f_in), .in_spin_damp, .in_count(1'b1), \
                .out_valid(f_pipe_valid), .out_tag(f_pipe_tag), .out_data(f_pipe), .ev_overflow(f_ev_ovf), \
                .ev_underflow(f_ev_unf), .ev_invalid(f_ev_inv));
        if (IINV_W == 1) begin : g_scalar
            `PGS_PIPE(pgs_contact_pipe_scalar, u_contact, c_in_valid, c_in, c_valid, c_tag, c_out, c_ev_ovf,
                      c_ev_unf, c_ev_inv)
        end else if (IINV_W == 6) begin : g_full
            `PGS_PIPE(pgs_contact_pipe_full, u_contact, c_in_valid, c_in, c_valid, c_tag, c_out, c_ev_ovf,
                      c_ev_unf, c_ev_inv)
        end else if (SOFT_CONTACT) begin : g_soft
            // the soft contact pipe (the same latency; keep_dyn, keep_static its last words)
            pgs_contact_pipe_soft #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(TAG_W),
                .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_contact (
                .clk, .rst, .in_valid(c_in_valid), .in_tag, .in_data(c_in), .in_soft, .in_count(1'b1),
                .out_valid(c_valid), .out_tag(c_tag), .out_data(c_out), .ev_overflow(c_ev_ovf),
                .ev_underflow(c_ev_unf), .ev_invalid(c_ev_inv));
        end else begin : g_rigid_pipe
            `PGS_PIPE(pgs_contact_pipe, u_contact, c_in_valid, c_in, c_valid, c_tag, c_out, c_ev_ovf, c_ev_unf,
                      c_ev_inv)
        end
        if (!SOFT_CONTACT) begin : g_no_soft
            wire unused_soft = ^{in_soft, in_keep_dyn, in_keep_static};
        end
        if (IINV_W == 1 && MU_W == 1) begin : g_f_scalar_mu
            `PGS_FRICTION_PIPE(pgs_friction_pipe_scalar_mu)
        end else if (IINV_W == 1) begin : g_f_scalar
            `PGS_FRICTION_PIPE(pgs_friction_pipe_scalar)
        end else if (IINV_W == 6 && MU_W == 1) begin : g_f_full_mu
            `PGS_FRICTION_PIPE(pgs_friction_pipe_full_mu)
        end else if (IINV_W == 6) begin : g_f_full
            `PGS_FRICTION_PIPE(pgs_friction_pipe_full)
        end else if (MU_W == 1) begin : g_f_mu
            `PGS_FRICTION_PIPE(pgs_friction_pipe_mu)
        end else if (TANGENTS_ON_CHIP) begin : g_f_tangents
            // the friction record carries no t0, t1: the pipe derives them from n (planeSpace of -n)
            `PGS_FRICTION_PIPE(pgs_friction_pipe_tb)
        end else begin : g_f_default
            `PGS_FRICTION_PIPE(pgs_friction_pipe)
        end
        `undef PGS_PIPE
        `undef PGS_FRICTION_PIPE
        // ALIGN: the friction results wait for the contact pipe's latency, so that every record retires LATENCY
        // cycles after it entered, in order
        if (F_ALIGN > 0) begin : g_f_align
            /* verilator lint_off UNUSEDSIGNAL */
            logic [F_ALIGN:0] f_align_valid;   // the line keeps the valid results: [F_ALIGN-1:0]
            /* verilator lint_on UNUSEDSIGNAL */
            fp_valid_pipe #(.LATENCY(F_ALIGN)) u_f_valid (.clk, .rst, .in_valid(f_pipe_valid),
                                                          .stage_valid(f_align_valid), .out_valid(f_valid));
            pgs_delay #(.WIDTH(TAG_W + 14*W), .DEPTH(F_ALIGN), .BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH)) u_f_data (
                .clk, .d({f_pipe_tag, f_pipe}), .valid(f_align_valid[F_ALIGN-1:0]), .q({f_tag, f_out}));
        end else begin : g_f_direct
            assign f_valid = f_pipe_valid;
            assign f_tag   = f_pipe_tag;
            assign f_out   = f_pipe;
        end
        // the issue keeps the two pipes' results apart: at most one is valid in a cycle
        assign out_valid    = c_valid || f_valid;
        assign out_kind     = f_valid;
        assign out_tag      = c_valid ? c_tag : f_tag;
        assign out_imp      = c_valid ? c_out[0 +: 4*W] : {(2*W)'(0), f_out[0 +: 2*W]};
        assign out_vel      = c_valid ? c_out[4*W +: 12*W] : f_out[2*W +: 12*W];
        assign ev_overflow  = c_ev_ovf + f_ev_ovf;
        assign ev_underflow = c_ev_unf + f_ev_unf;
        assign ev_invalid   = c_ev_inv + f_ev_inv;
    end
endmodule

`default_nettype wire
