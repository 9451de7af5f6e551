// pgs_sequencer: one step of the kernel (everything below the register file): the run's arguments, the phases, the
// body RAM and its ports, the counters and the error flags; the work of each phase in a module of its own:
//   pgs_seq_load       LOAD: the body-in records, checked, into the body RAM
//   pgs_seq_records    the constraint records offered (the stream pass by pass, or the record window) and their heads
//   pgs_seq_issue      the record checks and the issue: which lanes issue, which are rejected, the take
//   pgs_seq_hazards    the hazard CAM of the manifolds in flight, the two pipes' drain rule
//   pgs_seq_lane       a lane from issue to retire: impulses, stage 1, the datapath (pgs_lane_datapath), the tag
//   pgs_seq_retire     the trace port and the impulse-out stream
//   pgs_seq_integrate  INTEG: every body through the integrate pipe, out on m_body
//
// Phases after `start` (arguments sampled then):
//   LOAD   num_bodies body-in records from s_body into the body RAM (the constraint stream is already
//          being assembled meanwhile);
//   SOLVE  the passes of models.golden.contact_solver.pass_sequence (contact passes then friction passes, or
//          interleaved when opt_interleaved): num_manifolds records per pass, record k of a pass =
//          manifold slot k. A record issues (one per cycle at most, II = 1) when it is assembled and
//          no manifold in flight shares a dynamic body with it (pgs_hazard_cam), and -- with two pipes
//          per lane (SHARED_DATAPATH = 0), when the pass kind changes -- when the other pipe has drained
//          (retire stays in order, one write per body port per cycle). Issue cycle t: read bodies A, B
//          and the slot's impulses (registered RAMs); t+1: the lane's datapath (pgs_lane_datapath: one
//          shared datapath for both kinds, or the kind's pipe) takes the record; at retire
//          (t+1+LATENCY) the impulses are written to the slot and the velocities of the dynamic bodies to
//          the body RAM; the trace record leaves then.
//          With WINDOW > 0 (the window kernel) the records come from pgs_window instead: each
//          manifold's combined record is streamed once per fetch of arg_fetch_passes passes and the passes
//          trail each other by arg_lag slots over the on-chip ring (see pgs_window); records of several
//          passes interleave at issue, and the friction pipe's output is delayed to the contact pipe's
//          latency so that retire stays in issue order without draining at a kind change. With
//          IMPULSES_IN_RECORDS each fetch serves passes of one kind and streams that kind's records with the
//          impulses the fetch starts from; an impulse ring (per lane, at the record's ring address) carries the
//          updated impulses from pass to pass within the fetch, and the fetch's last pass writes them to m_imp
//          (rtl/README.md "Impulses in the records" under the window kernel).
//          With LANES > 1 (window kernel only) each window record holds LANES manifolds' combined records
//          (slots k * LANES .. k * LANES + LANES - 1, the host's lane plan: body-disjoint, an all-ones
//          header pads an empty lane); they issue together into LANES copies of the pipes, with 2 x LANES
//          body RAM ports, one impulse RAM bank per lane (lane l holds slots = l mod LANES) and one CAM
//          entry per issue; num_manifolds counts the slots (a multiple of LANES, else error 3).
//   DRAIN  until the last manifold has retired;
//   INTEG  every body in index order through pgs_integrate_pipe (a static body's record rides in the
//          tag and comes out unchanged), into an output FIFO (issue only with a free FIFO credit, so
//          the no-backpressure pipe never overflows), serialized to m_body beats, TLAST on the last
//          beat of the last body;
//   DONE   one cycle: done (= ap_done and ap_ready).
// Counters (pgs_run_counters; cleared at start, frozen after done): cycles (start .. done inclusive), stall cycles
// (SOLVE, a record is assembled but may not issue: hazard, CAM full, two pipes' switch drain or a busy body bank), bubble
// cycles (SOLVE, no record assembled), issued manifold-passes, rejected manifold-passes (issued +
// rejected + empty lanes = num_manifolds * 2 * iterations), and the floating-point events of the three datapaths
// (overflow, underflow, invalid: every operator result of an issued manifold-pass or of a dynamic body's
// integration; saturating at 2^32 - 1; fp_set pulses with the events of a cycle).
//
// Bad input (rtl/README.md "Bad input"; pgs_error_flags: err_set pulses a flag, err_code its code):
//   * body-in records are checked at load: a non-finite word (0x05), a negative inverse mass or inverse
//     inertia (0x06), or a record cut short by TLAST (0x02) makes a *bad body*: stored frozen (not
//     dynamic), every manifold naming it is rejected, integration passes its record through unchanged.
//     An early TLAST (fewer bodies than num_bodies, 0x02) loads the missing bodies as zero records, bad;
//     a late one (more) discards the extra beats up to TLAST (0x02). The step goes on.
//   * constraint records are checked at issue. A record is *rejected* (consumed, never issued: no pipe,
//     no trace, no write) when it names a body >= num_bodies or the same body twice (0x04), holds a
//     non-finite word (0x05), joins two static bodies (0x07), shares a dynamic body with an earlier issuing
//     lane of its window record (0x04; LANES > 1), names a bad body (no new flag), was cut
//     short by TLAST (0x01), or its manifold slot was rejected in an earlier pass of the step: a slot
//     once rejected stays rejected for the rest of the step (a one-bit-per-slot memory written for every
//     slot in the first pass), so the bodies it names see the manifold as absent from then on, exactly.
//     TLAST before the last record of a pass (0x01) ends the pass there: its missing slots are rejected
//     (one per cycle); TLAST missing on the last record (0x01) discards the extra beats up to the next
//     TLAST. Every pass stays in step with the host's transfers, so the step always ends.
//   * 0x03 bad argument (num_bodies > MAX_BODIES, num_manifolds > MAX_MANIFOLDS or iterations >= 2^16; with
//     WINDOW > 0 also fetch_passes = 0, fetch_passes > WINDOW_CTX, lag = 0 or (fetch_passes - 1) * lag + 2 >
//     WINDOW, and with IMPULSES_IN_RECORDS a fetch that would serve contact and friction passes): the step ends at
//     once, streams untouched.
`default_nettype none

module pgs_sequencer #(
    parameter int EXP_BITS       = 8,
    parameter int MAN_BITS       = 23,
    parameter int MAX_BODIES     = 65536,
    parameter int MAX_MANIFOLDS  = 262144,
    parameter int BODY_IN_W      = 128,
    parameter int CONS_W         = 512,
    parameter int BODY_OUT_W     = 128,
    parameter bit TRACE          = 1'b1,
    parameter int HAZARD_DEPTH   = 256,
    parameter int OUT_FIFO_DEPTH = 64,
    parameter int WINDOW         = 0,      // 0: every pass streams its records; > 0: record window of WINDOW records
    parameter int WINDOW_CTX     = 8,      // passes active at a time in the window (a power of two >= 2)
    parameter int LANES          = 1,      // manifolds issued per cycle (a power of two; > 1 needs WINDOW > 0)
    parameter int IINV_W         = 3,      // inverse-inertia words per body: 1 scalar, 3 diagonal, 6 symmetric 3x3
    parameter bit IMPULSES_IN_RECORDS = 1'b0,  // 1: impulses travel with the records, out on m_imp (no impulse RAM)
    parameter int IMP_FIFO_DEPTH = 256,    // IMPULSES_IN_RECORDS: impulse-out records between take and handshake
    parameter int MU_W           = 0,      // friction-coefficient words per friction record: 0 the constant, 1 a word
    parameter int BODY_BANKS     = 0,      // > 0 (LANES = 1): body velocities in banks; a busy bank stalls the issue
    parameter bit TANGENTS_ON_CHIP = 1'b0, // 1: friction records without t0, t1; pgs_friction_pipe_tb derives them
    parameter bit SOFT_CONTACT   = 1'b0,   // 1 (IINV_W = 3): the soft contact pipe, lam * keep before the add
    parameter int DELAY_BLOCK_MIN_DEPTH = 0, // the pipes' delay lines at least this deep in block RAM (0: LUT RAM)
    parameter bit SHARED_DATAPATH = 1'b1,  // 1: one datapath per lane for both passes; 0: a contact and a friction pipe
    parameter bit ADD_SHIFT_DSP  = 1'b0,   // 1: every fp_add of the pipes in its DSP48E2 form; 0: in the fabric
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int TRACE_W       = 16 * W + 64,
    localparam int IMP_OUT_W     = (LANES * 4 * W + 7) / 8 * 8
) (
    input  wire                   clk,
    input  wire                   rst,
    input  wire                   start,
    output logic                  idle,
    output logic                  done,
    input  wire  [31:0]           arg_num_bodies,
    input  wire  [31:0]           arg_num_manifolds,
    input  wire  [31:0]           arg_iterations,
    input  wire  [W-1:0]          arg_dt,
    input  wire  [W-1:0]          arg_gx,
    input  wire  [W-1:0]          arg_gy,
    input  wire  [W-1:0]          arg_gz,
    input  wire  [W-1:0]          arg_damping,
    input  wire                   opt_interleaved,
    input  wire  [31:0]           arg_lag,           // WINDOW > 0: slots a pass trails the pass before it
    input  wire  [31:0]           arg_fetch_passes,  // WINDOW > 0: passes served by one fetch of the records
    input  wire                   opt_soft,          // SOFT_CONTACT: the keep factors apply (clear: keep = 1)
    input  wire  [W-1:0]          arg_keep_dyn,      // SOFT_CONTACT: keep factor of a row of two dynamic bodies
    input  wire  [W-1:0]          arg_keep_static,   // SOFT_CONTACT: keep factor of a row with a static body
    input  wire  [BODY_IN_W-1:0]  s_body_tdata,
    input  wire                   s_body_tvalid,
    output logic                  s_body_tready,
    input  wire                   s_body_tlast,
    input  wire  [CONS_W-1:0]     s_cons_tdata,
    input  wire                   s_cons_tvalid,
    output logic                  s_cons_tready,
    input  wire                   s_cons_tlast,
    output logic [BODY_OUT_W-1:0] m_body_tdata,
    output logic                  m_body_tvalid,
    input  wire                   m_body_tready,
    output logic                  m_body_tlast,
    output logic [IMP_OUT_W-1:0]  m_imp_tdata,       // IMPULSES_IN_RECORDS: one record per slot and pass
    output logic                  m_imp_tvalid,
    input  wire                   m_imp_tready,
    output logic                  m_imp_tlast,
    output logic [7:0]            err_set,
    output logic [7:0]            err_code,
    output logic [2:0]            fp_set,       // {invalid, underflow, overflow} events this cycle
    output logic [63:0]           stat_cycles,
    output logic [31:0]           stat_stalls,
    output logic [31:0]           stat_bubbles,
    output logic [31:0]           stat_issued,
    output logic [31:0]           stat_rejected,
    output logic [31:0]           stat_fp_overflow,
    output logic [31:0]           stat_fp_underflow,
    output logic [31:0]           stat_fp_invalid,
    output logic [LANES-1:0]      trace_valid,
    output logic [LANES*TRACE_W-1:0] trace_data
);
    import pgs_seq_pkg::ITER_W, pgs_seq_pkg::EV_W;
    localparam int IDX_W     = $clog2(MAX_BODIES);
    localparam int SLOT_W    = $clog2(MAX_MANIFOLDS);
    localparam int BREC_W    = (14 + IINV_W) * W;                       // body record
    localparam int S1_WORDS  = pgs_seq_pkg::stage_words(MU_W, TANGENTS_ON_CHIP, IMPULSES_IN_RECORDS);
    localparam int RA_W      = WINDOW > 1 ? $clog2(WINDOW) : 1;

    if (LANES < 1 || (LANES & (LANES - 1)) != 0 || (LANES > 1 && WINDOW == 0)) begin : g_bad_lanes
        $error("pgs_sequencer: LANES must be a power of two, and LANES > 1 needs the window kernel (WINDOW > 0)");
    end
    if (IINV_W != 1 && IINV_W != 3 && IINV_W != 6) begin : g_bad_iinv
        $error("pgs_sequencer: IINV_W (inverse-inertia words per body) must be 1, 3 or 6");
    end
    if (MU_W != 0 && MU_W != 1) begin : g_bad_mu
        $error("pgs_sequencer: MU_W (friction-coefficient words per friction record) must be 0 or 1");
    end
    if (TANGENTS_ON_CHIP && (WINDOW > 0 || IINV_W != 3 || MU_W != 0)) begin : g_bad_tangents
        $error("pgs_sequencer: TANGENTS_ON_CHIP is a configuration of the streaming kernel (WINDOW = 0) with the diagonal inverse inertia (IINV_W = 3) and the constant friction coefficient (MU_W = 0)");
    end
    if (SOFT_CONTACT && (IINV_W != 3 || WINDOW > 0 || LANES > 1)) begin : g_bad_soft
        $error("pgs_sequencer: SOFT_CONTACT (the soft contact pipe) is built for IINV_W = 3 on the streaming kernel");
    end

    typedef enum logic [2:0] {S_IDLE, S_LOAD, S_SOLVE, S_DRAIN, S_INTEG, S_DONE} phase_t;
    phase_t phase;
    wire init     = phase == S_IDLE;   // the modules' counters start the next step afresh
    wire in_solve = phase == S_SOLVE;

    // ---------------- run arguments (sampled at start) ----------------
    logic [31:0] nb, nm;
    logic [ITER_W:0] iters, passes;   // passes = 2 * iterations
    logic        ilv;
    logic [31:0] r_lag, r_fetch;
    logic [W-1:0] r_dt, r_gx, r_gy, r_gz, r_damp;
    logic         r_soft;                 // SOFT_CONTACT: opt_soft and the keep factors of the run
    logic [W-1:0] r_keep_d, r_keep_s;
    // with the impulses in the records every fetch of the window kernel serves passes of one kind: fetch_passes
    // divides the iterations (contact passes, then friction passes), or 1 with the kinds interleaved
    logic mixed_fetch;
    always_comb begin
        mixed_fetch = 1'b0;
        for (int d = 1; d <= WINDOW_CTX; d++)
            if (arg_fetch_passes == 32'(d))
                mixed_fetch = opt_interleaved ? d != 1 : arg_iterations[ITER_W-1:0] % ITER_W'(d) != '0;
    end
    wire  bad_window = WINDOW > 0 && (arg_fetch_passes == 0 || arg_fetch_passes > 32'(WINDOW_CTX) || arg_lag == 0
                       || 64'(arg_fetch_passes - 1) * 64'(arg_lag) + 64'd2 > 64'(WINDOW)
                       || (IMPULSES_IN_RECORDS && mixed_fetch));
    wire  bad_args = arg_num_bodies > 32'(MAX_BODIES) || arg_num_manifolds > 32'(MAX_MANIFOLDS)
                     || arg_iterations >= 32'(1 << ITER_W) || bad_window
                     || (arg_num_manifolds & 32'(LANES - 1)) != 0;

    // the window's first pass starts in the first cycle of the step when it has passes and records (pgs_window; from the
    // arguments the registers above take at the start)
    wire  first_start = arg_iterations[ITER_W-1:0] != '0 && (arg_num_manifolds >> $clog2(LANES)) != 0;

    always_ff @(posedge clk) begin
        if (phase == S_IDLE && start) begin
            nb     <= arg_num_bodies;
            nm     <= arg_num_manifolds;
            iters  <= (ITER_W+1)'(arg_iterations[ITER_W-1:0]);
            passes <= {arg_iterations[ITER_W-1:0], 1'b0};
            ilv    <= opt_interleaved;
            r_lag  <= arg_lag;
            r_fetch <= arg_fetch_passes;
            r_dt   <= arg_dt;
            r_gx   <= arg_gx;
            r_gy   <= arg_gy;
            r_gz   <= arg_gz;
            r_damp <= arg_damping;
            r_soft <= opt_soft;
            r_keep_d <= arg_keep_dyn;
            r_keep_s <= arg_keep_static;
        end
    end

    // ---------------- body RAM ----------------
    // port 2l: body A of lane l, port 2l + 1: body B (flat vectors, port k at [k*width +: width])
    localparam int PORTS = 2 * LANES;
    logic [PORTS*IDX_W-1:0]  rd_addr, wr_addr, cand;
    logic [PORTS-1:0]        rd_en;
    logic [PORTS*BREC_W-1:0] rd_data, wr_data;
    logic [PORTS-1:0]        wr_en, dyn, bad;
    logic                    wr0_full, wr0_bad, rd0_bad, body_busy;
    pgs_body_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES), .PORTS(PORTS),
                   .IINV_W(IINV_W), .BODY_BANKS(BODY_BANKS)) u_body_ram (.clk, .rd_en, .rd_addr, .rd_data, .rd0_bad,
        .wr_en, .wr0_full, .wr0_bad, .wr_addr, .wr_data, .dyn_addr(cand), .dyn, .bad, .busy(body_busy));

    // ---------------- LOAD: the body-in records ----------------
    logic        load_wr, load_bad, load_done, err_body_tlast, err_body_nonfinite, err_bad_mass;
    logic [31:0] load_idx;
    logic [BREC_W-1:0] load_rec;
    pgs_seq_load #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .BODY_IN_W(BODY_IN_W), .IINV_W(IINV_W)) u_load (
        .clk, .rst, .init, .active(phase == S_LOAD), .nb, .s_body_tdata, .s_body_tvalid, .s_body_tready,
        .s_body_tlast, .wr_en(load_wr), .wr_idx(load_idx), .wr_rec(load_rec), .wr_bad(load_bad), .done(load_done),
        .err_tlast(err_body_tlast), .err_nonfinite(err_body_nonfinite), .err_bad_mass);

    // ---------------- constraint records: the stream pass by pass, or the record window ----------------
    // The record offered holds LANES manifold records of one pass (lane l: slot i_slot * LANES + l; the streaming
    // kernel has one lane): their bodies, spin-damping and shock bits and checks; stage 1 feeds the pass kind's words
    // to the lanes (l_words).
    logic                     rkind, crec_valid, crec_trunc, i_fill, c_flush, c_tlast_err, slot_last;
    logic [ITER_W:0]          i_pass;
    logic [31:0]              i_slot;
    logic [LANES*IDX_W-1:0]   la, lb;
    logic [LANES-1:0]         l_sd, l_empty_hdr, l_index, l_nonfinite, l_fa, l_fb, l_lin;
    logic [LANES*S1_WORDS*W-1:0] l_words;
    logic                     s1_kind;   // stage 1's pass kind (the lanes issue together)
    logic [RA_W-1:0]          w_addr;
    logic                     w_first, w_lastg, w_asm_move;
    logic [31:0]              w_asm_slot;
    logic [LANES-1:0]         w_head_seen, w_rej_q;
    logic                     take, slot_step;
    pgs_seq_records #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES), .CONS_W(CONS_W),
                      .WINDOW(WINDOW), .WINDOW_CTX(WINDOW_CTX), .LANES(LANES),
                      .IMPULSES_IN_RECORDS(IMPULSES_IN_RECORDS), .MU_W(MU_W), .TANGENTS_ON_CHIP(TANGENTS_ON_CHIP))
        u_records (
        .clk, .rst, .init, .first_start(first_start), .fetch_en(phase == S_LOAD || in_solve), .nb, .nm, .iters, .passes,
        .ilv, .lag(r_lag),
        .fetch(r_fetch), .s_cons_tdata, .s_cons_tvalid, .s_cons_tready, .s_cons_tlast, .rec_valid(crec_valid),
        .rec_kind(rkind), .rec_trunc(crec_trunc), .pass(i_pass), .slot(i_slot), .slot_last, .fill(i_fill),
        .flush(c_flush), .err_tlast(c_tlast_err), .la, .lb, .l_sd, .l_empty_hdr, .l_index, .l_nonfinite, .l_fa,
        .l_fb, .l_lin, .l_words, .s1_kind, .take, .slot_step, .w_addr, .w_first, .w_lastg, .w_asm_move,
        .w_asm_slot, .w_head_seen, .w_rej_q);

    // ---------------- issue: the record checks, the hazards ----------------
    logic [LANES-1:0] l_go, l_issue, l_reject, l_retire;
    logic issue, fill, imp_room, may_issue, hazard, cam_empty, retire;
    logic err_body_index, err_cons_nonfinite, err_static_pair;
    pgs_seq_issue #(.MAX_BODIES(MAX_BODIES), .MAX_MANIFOLDS(MAX_MANIFOLDS), .WINDOW(WINDOW), .LANES(LANES),
                    .IMPULSES_IN_RECORDS(IMPULSES_IN_RECORDS), .BODY_BANKS(BODY_BANKS)) u_issue (
        .clk, .in_solve, .rec_valid(crec_valid), .rec_trunc(crec_trunc), .fill(i_fill), .imp_room, .may_issue,
        .pass(i_pass), .slot(i_slot), .la, .lb, .l_empty_hdr, .l_index, .l_nonfinite, .dyn, .bad, .w_asm_move,
        .w_asm_slot, .w_rej_q, .w_head_seen, .take, .l_go, .l_issue, .l_reject, .issue, .fill_step(fill),
        .slot_step, .err_body_index, .err_nonfinite(err_cons_nonfinite), .err_static_pair);
    pgs_seq_hazards #(.MAX_BODIES(MAX_BODIES), .HAZARD_DEPTH(HAZARD_DEPTH), .LANES(LANES), .WINDOW(WINDOW),
                      .SHARED_DATAPATH(SHARED_DATAPATH)) u_hazards (
        .clk, .rst, .init, .la, .lb, .dyn, .l_go, .kind(rkind), .issue, .retire, .body_busy, .cand, .hazard,
        .may_issue, .drained(cam_empty));
    assign retire = l_retire != '0;
    always_ff @(posedge clk) begin
        if (issue) s1_kind <= rkind;
    end
    wire  [ITER_W:0]   i_iter_full = ilv ? (i_pass >> 1) : (i_pass >= iters ? i_pass - iters : i_pass);
    wire  [ITER_W-1:0] i_iter = i_iter_full[ITER_W-1:0];

    // ---------------- the lanes: issue to retire ----------------
    // Every manifold retires the lane datapath's LATENCY + 1 cycles after its issue with the shared datapath and in
    // the window kernel (its two pipes aligned to the contact pipe's latency), so the lanes of an issue retire
    // together and one CAM entry leaves.
    logic [LANES-1:0]          l_fret, l_write_a, l_write_b, l_rlastg;
    logic [LANES*IDX_W-1:0]    l_ra, l_rb;
    logic [LANES*12*W-1:0]     l_vel;             // vA wA vB wB
    logic [LANES*4*W-1:0]      l_imp;
    logic [LANES*SLOT_W-1:0]   l_rslot;
    logic [LANES*ITER_W-1:0]   l_riter;
    logic [LANES*3*EV_W-1:0]   lane_ev;           // {invalid, underflow, overflow} of each lane's datapath
    for (genvar l = 0; l < LANES; l++) begin : g_lane
        wire [31:0] lslot = i_slot * LANES + 32'(l);   // the lane's manifold slot
        logic [RA_W-1:0] r_addr;                      // window kernel: the retiring record's ring address
        pgs_seq_lane #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES),
                       .MAX_MANIFOLDS(MAX_MANIFOLDS), .WINDOW(WINDOW), .LANES(LANES), .IINV_W(IINV_W),
                       .IMPULSES_IN_RECORDS(IMPULSES_IN_RECORDS), .MU_W(MU_W), .TANGENTS_ON_CHIP(TANGENTS_ON_CHIP),
                       .SOFT_CONTACT(SOFT_CONTACT), .SHARED_DATAPATH(SHARED_DATAPATH),
                       .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_lane (
            .clk, .rst, .issue(l_issue[l]), .kind(rkind), .s1_kind, .iter(i_iter), .slot(i_slot),
            .lslot(lslot[SLOT_W-1:0]), .la(la[l*IDX_W +: IDX_W]), .lb(lb[l*IDX_W +: IDX_W]), .dyn_a(dyn[2*l]),
            .dyn_b(dyn[2*l+1]), .sd(l_sd[l]), .fa(l_fa[l]), .fb(l_fb[l]), .lin(l_lin[l]),
            .words(l_words[l*S1_WORDS*W +: S1_WORDS*W]), .w_addr, .w_first, .w_lastg,
            .ra(rd_data[2*l*BREC_W +: BREC_W]), .rb(rd_data[(2*l+1)*BREC_W +: BREC_W]), .soft_on(r_soft),
            .keep_dyn(r_keep_d), .keep_static(r_keep_s), .retire(l_retire[l]), .r_kind(l_fret[l]),
            .r_imp(l_imp[l*4*W +: 4*W]), .r_vel(l_vel[l*12*W +: 12*W]), .r_a(l_ra[l*IDX_W +: IDX_W]),
            .r_b(l_rb[l*IDX_W +: IDX_W]), .r_write_a(l_write_a[l]), .r_write_b(l_write_b[l]),
            .r_slot(l_rslot[l*SLOT_W +: SLOT_W]), .r_iter(l_riter[l*ITER_W +: ITER_W]), .r_addr,
            .r_lastg(l_rlastg[l]), .r_ev(lane_ev[l*3*EV_W +: 3*EV_W]));
        // the lane's slot bits above SLOT_W; the retiring ring address (the lane's impulse ring's)
        wire unused_lane = ^{lslot[31:SLOT_W], r_addr};
    end

    // ---------------- retire: the trace, the impulse-out stream ----------------
    logic imp_idle;   // no impulse-out record pending
    pgs_seq_retire #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_MANIFOLDS(MAX_MANIFOLDS), .LANES(LANES),
                     .TRACE(TRACE), .IMPULSES_IN_RECORDS(IMPULSES_IN_RECORDS), .IMP_FIFO_DEPTH(IMP_FIFO_DEPTH)) u_retire (
        .clk, .rst, .slot_step, .slot_last, .w_lastg, .issue, .l_retire, .l_kind(l_fret), .l_lastg(l_rlastg),
        .l_imp, .l_vel, .l_slot(l_rslot), .l_iter(l_riter), .imp_room, .imp_idle, .m_imp_tdata, .m_imp_tvalid,
        .m_imp_tready, .m_imp_tlast, .trace_valid, .trace_data);

    // ---------------- INTEG: the bodies through the integrate pipe, out on m_body ----------------
    logic [31:0]     int_idx;
    logic            integ_done;
    logic [EV_W-1:0] i_ev_ovf, i_ev_unf, i_ev_inv;
    pgs_seq_integrate #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .BODY_OUT_W(BODY_OUT_W),
                        .OUT_FIFO_DEPTH(OUT_FIFO_DEPTH), .IINV_W(IINV_W),
                        .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_integrate (
        .clk, .rst, .init, .active(phase == S_INTEG), .nb, .dt(r_dt), .damping(r_damp), .gx(r_gx), .gy(r_gy),
        .gz(r_gz), .rd_idx(int_idx), .rd_rec(rd_data[0 +: BREC_W]), .rd_bad(rd0_bad), .m_body_tdata, .m_body_tvalid,
        .m_body_tready, .m_body_tlast, .done(integ_done), .ev_overflow(i_ev_ovf), .ev_underflow(i_ev_unf),
        .ev_invalid(i_ev_inv));

    // body RAM ports: LOAD writes whole records on port 0; SOLVE retire writes v/w of lane l's A (port 2l) and B
    // (port 2l + 1), and reads the bodies of the offered record's issuing lanes; INTEG reads on port 0
    always_comb begin
        wr_en    = '0;
        wr0_full = 1'b0;
        wr0_bad  = 1'b0;
        wr_data  = '0;
        rd_addr  = cand;
        for (int l = 0; l < LANES; l++) rd_en[2*l +: 2] = {2{l_go[l]}};
        if (phase == S_INTEG) rd_en[0] = 1'b1;
        for (int l = 0; l < LANES; l++) begin
            wr_en[2*l]   = l_retire[l] && l_write_a[l];
            wr_en[2*l+1] = l_retire[l] && l_write_b[l];
            wr_addr[2*l*IDX_W +: IDX_W]     = l_ra[l*IDX_W +: IDX_W];
            wr_addr[(2*l+1)*IDX_W +: IDX_W] = l_rb[l*IDX_W +: IDX_W];
            wr_data[2*l*BREC_W + 7*W +: 6*W]     = l_vel[l*12*W +: 6*W];
            wr_data[(2*l+1)*BREC_W + 7*W +: 6*W] = l_vel[l*12*W + 6*W +: 6*W];
        end
        if (phase == S_LOAD) begin
            wr_en[0]  = load_wr;
            wr0_full  = 1'b1;
            wr0_bad   = load_bad;
            wr_addr[0 +: IDX_W] = load_idx[IDX_W-1:0];
            wr_data[0 +: BREC_W] = load_rec;
        end
        if (phase == S_INTEG) rd_addr[0 +: IDX_W] = int_idx[IDX_W-1:0];
    end

    // ---------------- phase machine and counters ----------------
    wire solve_last = slot_step && i_pass == passes - 1 && slot_last;
    wire solve_work = nm != 0 && passes != 0;

    always_ff @(posedge clk) begin
        if (rst) begin
            phase <= S_IDLE;
        end else begin
            unique case (phase)
                S_IDLE:  if (start) phase <= bad_args ? S_DONE : (arg_num_bodies != 0 ? S_LOAD : S_INTEG);
                // LOAD ends with the last body written and no extra body beats left to discard
                S_LOAD:  if (load_done) phase <= solve_work ? S_SOLVE : S_INTEG;
                S_SOLVE: if (solve_last) phase <= S_DRAIN;
                S_DRAIN: if (cam_empty && !c_flush) phase <= S_INTEG;
                // (and, with IMPULSES_IN_RECORDS, the last impulse-out record taken)
                S_INTEG: if (integ_done && imp_idle) phase <= S_DONE;
                S_DONE:  phase <= S_IDLE;
                default: phase <= S_IDLE;
            endcase
        end
    end
    assign idle = phase == S_IDLE;
    assign done = phase == S_DONE;

    // run statistics and the datapaths' floating-point events (each pipe reports the previous cycle's; they
    // arrive at most LATENCY + 1 cycles after an input, before the step's last body-out beat)
    pgs_run_counters #(.LANES(LANES), .EV_W(EV_W)) u_counters (
        .clk, .rst, .idle, .start, .stall(in_solve && crec_valid && !i_fill && !take),
        .bubble(in_solve && !crec_valid && !i_fill), .issued(l_issue), .rejected(l_reject), .fill_rejected(fill),
        .lane_ev, .int_ev_ovf(i_ev_ovf), .int_ev_unf(i_ev_unf), .int_ev_inv(i_ev_inv), .fp_set, .stat_cycles,
        .stat_stalls, .stat_bubbles, .stat_issued, .stat_rejected, .stat_fp_overflow, .stat_fp_underflow,
        .stat_fp_invalid);

    // ---------------- errors ----------------
    // the conditions of codes 1..7 this cycle, encoded into err_set / err_code by pgs_error_flags.
    pgs_error_flags u_errors (
        .cons_tlast(c_tlast_err), .body_tlast(err_body_tlast), .bad_args(phase == S_IDLE && start && bad_args),
        .body_index(err_body_index), .non_finite(err_cons_nonfinite || err_body_nonfinite),
        .negative_mass(err_bad_mass), .static_pair(err_static_pair), .err_set, .err_code);

    // Not needed (Verilator's *unused* naming convention): the iteration's overflow bit, what the lanes and the
    // integration do not read of the bodies, the body indices' bits above IDX_W, the hazard alone (may_issue has it)
    logic unused_seq;
    always_comb begin
        unused_seq = ^{i_iter_full[ITER_W], rd_data, load_idx[31:IDX_W], int_idx[31:IDX_W], hazard};
        if (!SOFT_CONTACT) unused_seq ^= ^{r_soft, r_keep_d, r_keep_s};   // the rigid kernel reads no keep factor
    end
endmodule

`default_nettype wire
