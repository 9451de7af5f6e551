// pgs_sequencer: one step of the kernel (everything below the register file).
//
// Phases after `start` (arguments sampled then):
//   LOAD   num_bodies body-in records from s_body into the body RAM (the constraint stream is already
//          being assembled meanwhile);
//   SOLVE  the passes of models.contact_solver.pass_sequence (contact passes then friction passes, or
//          interleaved when opt_interleaved): num_manifolds records per pass, record k of a pass =
//          manifold slot k. A record issues (one per cycle at most, II = 1) when it is assembled and
//          no manifold in flight shares a dynamic body with it (pgs_hazard_cam), and -- when the pass
//          kind changes -- when the other pipe has drained (retire stays in order, one write per
//          body port per cycle). Issue cycle t: read bodies A, B and the slot's impulses (registered
//          RAMs); t+1: the contact or friction pipe takes the record; at retire (t+1+LATENCY) the
//          impulses are written to the slot and the velocities of the dynamic bodies to the body RAM;
//          the trace record leaves then.
//   DRAIN  until the last manifold has retired;
//   INTEG  every body in index order through pgs_integrate_pipe (a static body's record rides in the
//          tag and comes out unchanged), into an output FIFO (issue only with a free FIFO credit, so
//          the no-backpressure pipe never overflows), serialized to m_body beats, TLAST on the last
//          beat of the last body;
//   DONE   one cycle: done (= ap_done and ap_ready).
// Counters (cleared at start, frozen after done): cycles (start .. done inclusive), stall cycles
// (SOLVE, a record is assembled but may not issue: hazard, CAM full or pipe switch drain), bubble
// cycles (SOLVE, no record assembled), issued manifold-passes.
// Errors (err_set pulses, err_code): 0x01 constraint TLAST not on exactly the last beat of each
// pass; 0x02 body-in TLAST not on exactly the last beat of the last body; 0x03 bad argument
// (num_bodies > MAX_BODIES, num_manifolds > MAX_MANIFOLDS or iterations >= 2^16: the step ends at once,
// streams untouched); 0x04 a record names a body index >= num_bodies (the index is used modulo
// MAX_BODIES). Flags: bit k-1 for code k.
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
    parameter bit TEST_FRICTION_SIGN_BUG = 1'b0,  // test only (pgs_kernel): an injected friction-pass bug
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int TRACE_W       = 16 * W + 64
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
    output logic [7:0]            err_set,
    output logic [7:0]            err_code,
    output logic [63:0]           stat_cycles,
    output logic [31:0]           stat_stalls,
    output logic [31:0]           stat_bubbles,
    output logic [31:0]           stat_issued,
    output logic                  trace_valid,
    output logic [TRACE_W-1:0]    trace_data
);
    localparam int IDX_W     = $clog2(MAX_BODIES);
    localparam int SLOT_W    = $clog2(MAX_MANIFOLDS);
    localparam int ITER_W    = 16;
    localparam int BREC_W    = 17 * W;                                  // body record
    localparam int OREC_W    = 13 * W;                                  // body-out record
    localparam int B_BEATS   = (BREC_W + BODY_IN_W - 1) / BODY_IN_W;
    localparam int O_BEATS   = (OREC_W + BODY_OUT_W - 1) / BODY_OUT_W;
    localparam int C_BEATS   = (64 + 23 * W + CONS_W - 1) / CONS_W;     // contact record
    localparam int F_BEATS   = (64 + 14 * W + CONS_W - 1) / CONS_W;     // friction record
    localparam int CM_BEATS  = C_BEATS > F_BEATS ? C_BEATS : F_BEATS;
    localparam int CREC_W    = CM_BEATS * CONS_W;
    localparam int CNEED_W   = $clog2(CM_BEATS + 1);
    localparam int BNEED_W   = $clog2(B_BEATS + 1);
    localparam int STAG_W    = SLOT_W + ITER_W + 2 * IDX_W + 2;        // solver pipes' tag
    localparam int ITAG_W    = 1 + OREC_W;                              // integrate pipe's tag
    localparam int OBEAT_W   = $clog2(O_BEATS + 1);

    localparam bit CONTACT  = 1'b0;
    localparam bit FRICTION = 1'b1;

    typedef enum logic [2:0] {S_IDLE, S_LOAD, S_SOLVE, S_DRAIN, S_INTEG, S_DONE} phase_t;
    phase_t phase;

    // ---------------- run arguments (sampled at start) ----------------
    logic [31:0] nb, nm;
    logic [ITER_W:0] iters, passes;   // passes = 2 * iterations
    logic        ilv;
    logic [W-1:0] r_dt, r_gx, r_gy, r_gz, r_damp;
    wire  bad_args = arg_num_bodies > 32'(MAX_BODIES) || arg_num_manifolds > 32'(MAX_MANIFOLDS)
                     || arg_iterations >= 32'(1 << ITER_W);

    always_ff @(posedge clk) begin
        if (phase == S_IDLE && start) begin
            nb     <= arg_num_bodies;
            nm     <= arg_num_manifolds;
            iters  <= (ITER_W+1)'(arg_iterations[ITER_W-1:0]);
            passes <= {arg_iterations[ITER_W-1:0], 1'b0};
            ilv    <= opt_interleaved;
            r_dt   <= arg_dt;
            r_gx   <= arg_gx;
            r_gy   <= arg_gy;
            r_gz   <= arg_gz;
            r_damp <= arg_damping;
        end
    end

    function automatic logic kind_of(input logic [ITER_W:0] p, input logic il, input logic [ITER_W:0] it);
        return il ? p[0] : (p >= it);
    endfunction

    // ---------------- body RAM ----------------
    logic [IDX_W-1:0]  rd0_addr, rd1_addr, wr0_addr, wr1_addr, dyn0_addr, dyn1_addr;
    logic [BREC_W-1:0] rd0_data, rd1_data, wr0_data, wr1_data;
    logic              wr0_en, wr0_full, wr1_en, dyn0, dyn1;

    pgs_body_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES)) u_body_ram (
        .clk, .rd0_addr, .rd0_data, .rd1_addr, .rd1_data,
        .wr0_en, .wr0_full, .wr0_addr, .wr0_data, .wr1_en, .wr1_full(1'b0), .wr1_addr, .wr1_data,
        .dyn0_addr, .dyn0, .dyn1_addr, .dyn1);

    // ---------------- body-in stream ----------------
    logic [B_BEATS*BODY_IN_W-1:0] brec;
    logic        brec_valid, brec_last, b_done, b_unused_tag;
    logic [31:0] b_asm_cnt, load_idx;
    pgs_record_asm #(.BEAT_W(BODY_IN_W), .MAX_BEATS(B_BEATS), .TAG_W(1)) u_body_asm (
        .clk, .rst, .enable(phase == S_LOAD && b_asm_cnt < nb), .need(BNEED_W'(B_BEATS)), .in_tag(1'b0),
        .s_tdata(s_body_tdata), .s_tvalid(s_body_tvalid), .s_tlast(s_body_tlast), .s_tready(s_body_tready),
        .done(b_done), .rec_data(brec), .rec_tag(b_unused_tag), .rec_last(brec_last), .rec_valid(brec_valid),
        .rec_ready(1'b1));

    // ---------------- constraint stream ----------------
    logic [ITER_W:0] a_pass;   // pass of the record being assembled
    logic [31:0]     a_slot;
    wire             a_kind = kind_of(a_pass, ilv, iters);
    wire             a_last = a_slot == nm - 1;
    logic [CREC_W-1:0] crec;
    logic [1:0]      crec_tag;  // {last record of its pass, kind}
    logic            crec_valid, crec_last, c_done, issue;
    pgs_record_asm #(.BEAT_W(CONS_W), .MAX_BEATS(CM_BEATS), .TAG_W(2)) u_cons_asm (
        .clk, .rst, .enable((phase == S_LOAD || phase == S_SOLVE) && a_pass < passes),
        .need(a_kind ? CNEED_W'(F_BEATS) : CNEED_W'(C_BEATS)), .in_tag({a_last, a_kind}),
        .s_tdata(s_cons_tdata), .s_tvalid(s_cons_tvalid), .s_tlast(s_cons_tlast), .s_tready(s_cons_tready),
        .done(c_done), .rec_data(crec), .rec_tag(crec_tag), .rec_last(crec_last), .rec_valid(crec_valid),
        .rec_ready(issue));

    // ---------------- issue ----------------
    wire [63:0]      hdr    = crec[63:0];
    wire [31:0]      hdr_a  = hdr[31:0];
    wire [31:0]      hdr_b  = {1'b0, hdr[62:32]};
    wire [IDX_W-1:0] cand_a = hdr_a[IDX_W-1:0];
    wire [IDX_W-1:0] cand_b = hdr_b[IDX_W-1:0];
    wire             rkind  = crec_tag[0];
    logic hazard, cam_full, cam_empty, retire, last_kind;
    logic [ITER_W:0] i_pass;
    logic [31:0]     i_slot;
    wire  [ITER_W:0]   i_iter_full = ilv ? (i_pass >> 1) : (i_pass >= iters ? i_pass - iters : i_pass);
    wire  [ITER_W-1:0] i_iter = i_iter_full[ITER_W-1:0];
    wire  in_solve = phase == S_SOLVE;
    wire  kind_ok  = rkind == last_kind || cam_empty;
    assign issue = in_solve && crec_valid && !hazard && !cam_full && kind_ok;

    pgs_hazard_cam #(.IDX_W(IDX_W), .DEPTH(HAZARD_DEPTH)) u_cam (
        .clk, .rst, .cand_a, .cand_a_dyn(dyn0), .cand_b, .cand_b_dyn(dyn1), .hazard, .push(issue), .pop(retire),
        .full(cam_full), .empty(cam_empty));
    assign dyn0_addr = cand_a;
    assign dyn1_addr = cand_b;

    // impulse RAM
    logic [SLOT_W-1:0] imp_wr_addr;
    logic [4*W-1:0]    rd_lam, wr_lam;
    logic [2*W-1:0]    rd_lamT, wr_lamT;
    logic              wr_lam_en, wr_lamT_en;
    pgs_impulse_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_MANIFOLDS(MAX_MANIFOLDS)) u_imp_ram (
        .clk, .rd_addr(i_slot[SLOT_W-1:0]), .rd_zero_lam(rkind == CONTACT && i_iter == '0),
        .rd_zero_lamT(rkind == FRICTION && i_iter == '0), .rd_lam, .rd_lamT, .wr_addr(imp_wr_addr), .wr_lam_en,
        .wr_lam, .wr_lamT_en, .wr_lamT);

    // stage 1: the record and tag of the manifold issued in the previous cycle
    logic              s1_valid, s1_kind, s1_sd;
    logic [23*W-1:0]   s1_words;
    logic [STAG_W-1:0] s1_tag;
    always_ff @(posedge clk) begin
        if (rst) s1_valid <= 1'b0;
        else     s1_valid <= issue;
    end
    always_ff @(posedge clk) begin
        if (issue) begin
            s1_kind  <= rkind;
            s1_sd    <= hdr[63];
            s1_words <= crec[64 +: 23*W];
            s1_tag   <= {i_slot[SLOT_W-1:0], i_iter, cand_a, cand_b, dyn0, dyn1};
        end
    end

    // body fields of the stage-1 reads (A on port 0, B on port 1)
    logic [53*W-1:0] c_in;
    logic [46*W-1:0] f_in;
    always_comb begin
        c_in = '0;
        c_in[0 +: 23*W] = s1_words;
        c_in[23*W +: 4*W] = rd_lam;
        c_in[27*W +: 3*W] = rd0_data[0 +: 3*W];      // xA
        c_in[30*W +: 3*W] = rd1_data[0 +: 3*W];      // xB
        c_in[33*W +: 6*W] = rd0_data[7*W +: 6*W];    // vA, wA
        c_in[39*W +: 6*W] = rd1_data[7*W +: 6*W];    // vB, wB
        c_in[45*W +: W]   = rd0_data[13*W +: W];        // mInvA
        c_in[46*W +: W]   = rd1_data[13*W +: W];        // mInvB
        c_in[47*W +: 3*W] = rd0_data[14*W +: 3*W];   // IInvA
        c_in[50*W +: 3*W] = rd1_data[14*W +: 3*W];   // IInvB
        f_in = '0;
        f_in[0 +: 14*W]   = s1_words[0 +: 14*W];
        f_in[14*W +: 4*W] = rd_lam;
        f_in[18*W +: 2*W] = rd_lamT;
        f_in[20*W +: 3*W] = rd0_data[0 +: 3*W];
        f_in[23*W +: 3*W] = rd1_data[0 +: 3*W];
        f_in[26*W +: 6*W] = rd0_data[7*W +: 6*W];
        f_in[32*W +: 6*W] = rd1_data[7*W +: 6*W];
        f_in[38*W +: W]   = rd0_data[13*W +: W];
        f_in[39*W +: W]   = rd1_data[13*W +: W];
        f_in[40*W +: 3*W] = rd0_data[14*W +: 3*W];
        f_in[43*W +: 3*W] = rd1_data[14*W +: 3*W];
    end

    logic              c_out_valid, f_out_valid;
    logic [STAG_W-1:0] c_out_tag, f_out_tag;
    logic [16*W-1:0]   c_out;
    logic [14*W-1:0]   f_out;
    pgs_contact_pipe #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(STAG_W)) u_contact (
        .clk, .rst, .in_valid(s1_valid && s1_kind == CONTACT), .in_tag(s1_tag), .in_data(c_in),
        .out_valid(c_out_valid), .out_tag(c_out_tag), .out_data(c_out));
    pgs_friction_pipe #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(STAG_W),
                        .TEST_FRICTION_SIGN_BUG(TEST_FRICTION_SIGN_BUG)) u_friction (
        .clk, .rst, .in_valid(s1_valid && s1_kind == FRICTION), .in_tag(s1_tag), .in_data(f_in),
        .in_spin_damp(s1_sd), .out_valid(f_out_valid), .out_tag(f_out_tag), .out_data(f_out));

    // ---------------- retire ----------------
    assign retire = c_out_valid || f_out_valid;
    wire [STAG_W-1:0] r_tag   = c_out_valid ? c_out_tag : f_out_tag;
    wire [12*W-1:0]   r_vel   = c_out_valid ? c_out[4*W +: 12*W] : f_out[2*W +: 12*W];  // vA wA vB wB
    wire [4*W-1:0]    r_imp   = c_out_valid ? c_out[0 +: 4*W] : {(2*W)'(0), f_out[0 +: 2*W]};
    wire              r_dyn_b = r_tag[0];
    wire              r_dyn_a = r_tag[1];
    wire [IDX_W-1:0]  r_b     = r_tag[2 +: IDX_W];
    wire [IDX_W-1:0]  r_a     = r_tag[2 + IDX_W +: IDX_W];
    wire [ITER_W-1:0] r_iter  = r_tag[2 + 2*IDX_W +: ITER_W];
    wire [SLOT_W-1:0] r_slot  = r_tag[2 + 2*IDX_W + ITER_W +: SLOT_W];

    assign imp_wr_addr = r_slot;
    assign wr_lam_en   = c_out_valid;
    assign wr_lam      = c_out[0 +: 4*W];
    assign wr_lamT_en  = f_out_valid;
    assign wr_lamT     = f_out[0 +: 2*W];

    // body RAM ports: LOAD writes whole records on port 0; SOLVE retire writes v/w of A (port 0), B (port 1)
    logic [31:0] int_idx;
    always_comb begin
        wr0_en   = 1'b0;
        wr0_full = 1'b0;
        wr0_addr = r_a;
        wr0_data = '0;
        wr0_data[7*W +: 6*W] = r_vel[0 +: 6*W];
        if (phase == S_LOAD) begin
            wr0_en   = brec_valid;
            wr0_full = 1'b1;
            wr0_addr = load_idx[IDX_W-1:0];
            wr0_data = brec[0 +: BREC_W];
        end else if (retire && r_dyn_a) begin
            wr0_en = 1'b1;
        end
        wr1_en   = retire && r_dyn_b;
        wr1_addr = r_b;
        wr1_data = '0;
        wr1_data[7*W +: 6*W] = r_vel[6*W +: 6*W];
        rd0_addr = phase == S_INTEG ? int_idx[IDX_W-1:0] : cand_a;
        rd1_addr = cand_b;
    end

    generate
        if (TRACE) begin : g_trace
            always_comb begin
                trace_valid = retire;
                trace_data  = '0;
                trace_data[0 +: 4*W]        = r_imp;
                trace_data[4*W +: 12*W]     = r_vel;
                trace_data[16*W +: 32]      = 32'(r_slot);
                trace_data[16*W + 32 +: 16] = r_iter;
                trace_data[16*W + 48]       = f_out_valid;
            end
        end else begin : g_no_trace
            assign trace_valid = 1'b0;
            assign trace_data  = '0;
            // the iteration field only feeds the trace
            wire unused_trace = ^{r_iter};
        end
    endgenerate

    // ---------------- integration and body-out ----------------
    logic [31:0] credits;        // bodies in the integrate pipe or in the output FIFO
    logic [31:0] out_cnt;        // body-out records completely sent
    logic [OBEAT_W-1:0] out_beat;
    wire  int_issue = phase == S_INTEG && int_idx < nb && credits < 32'(OUT_FIFO_DEPTH);
    logic i1_valid;
    always_ff @(posedge clk) begin
        if (rst) i1_valid <= 1'b0;
        else     i1_valid <= int_issue;
    end
    wire i1_static = rd0_data[13*W + MAN_BITS +: EXP_BITS] == '0;
    wire [18*W-1:0] i_in = {r_gz, r_gy, r_gx, r_damp, r_dt, rd0_data[0 +: OREC_W]};
    logic              io_valid;
    logic [ITAG_W-1:0] io_tag;
    logic [OREC_W-1:0] io_data;
    pgs_integrate_pipe #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(ITAG_W)) u_integrate (
        .clk, .rst, .in_valid(i1_valid), .in_tag({i1_static, rd0_data[0 +: OREC_W]}), .in_data(i_in),
        .out_valid(io_valid), .out_tag(io_tag), .out_data(io_data));

    logic [OREC_W-1:0] ofifo_head;
    logic ofifo_empty, ofifo_full;
    wire  out_hs   = m_body_tvalid && m_body_tready;
    wire  out_pop  = out_hs && out_beat == OBEAT_W'(O_BEATS - 1);
    pgs_fifo #(.DATA_W(OREC_W), .DEPTH(OUT_FIFO_DEPTH)) u_ofifo (
        .clk, .rst, .push(io_valid), .push_data(io_tag[OREC_W] ? io_tag[OREC_W-1:0] : io_data), .pop(out_pop),
        .head(ofifo_head), .empty(ofifo_empty), .full(ofifo_full));
    wire [O_BEATS*BODY_OUT_W-1:0] out_rec = (O_BEATS*BODY_OUT_W)'(ofifo_head);
    assign m_body_tvalid = !ofifo_empty;
    assign m_body_tdata  = out_rec[out_beat * BODY_OUT_W +: BODY_OUT_W];
    assign m_body_tlast  = out_beat == OBEAT_W'(O_BEATS - 1) && out_cnt == nb - 1;

    // ---------------- phase machine and counters ----------------
    wire load_last  = brec_valid && load_idx == nb - 1;
    wire issue_last = issue && i_pass == passes - 1 && i_slot == nm - 1;
    wire solve_work = nm != 0 && passes != 0;

    always_ff @(posedge clk) begin
        if (rst) begin
            phase <= S_IDLE;
        end else begin
            unique case (phase)
                S_IDLE:  if (start) phase <= bad_args ? S_DONE : (arg_num_bodies != 0 ? S_LOAD : S_INTEG);
                S_LOAD:  if (load_last) phase <= solve_work ? S_SOLVE : S_INTEG;
                S_SOLVE: if (issue_last) phase <= S_DRAIN;
                S_DRAIN: if (cam_empty) phase <= S_INTEG;
                S_INTEG: if ((out_pop && out_cnt == nb - 1) || nb == 0) phase <= S_DONE;
                S_DONE:  phase <= S_IDLE;
                default: phase <= S_IDLE;
            endcase
        end
    end
    assign idle = phase == S_IDLE;
    assign done = phase == S_DONE;

    always_ff @(posedge clk) begin
        if (rst) begin
            stat_cycles  <= '0;
            stat_stalls  <= '0;
            stat_bubbles <= '0;
            stat_issued  <= '0;
        end else if (phase == S_IDLE) begin
            if (start) begin
                stat_cycles  <= 64'd1;
                stat_stalls  <= '0;
                stat_bubbles <= '0;
                stat_issued  <= '0;
            end
        end else begin
            stat_cycles <= stat_cycles + 1'b1;
            if (in_solve && crec_valid && !issue) stat_stalls <= stat_stalls + 1'b1;
            if (in_solve && !crec_valid) stat_bubbles <= stat_bubbles + 1'b1;
            if (issue) stat_issued <= stat_issued + 1'b1;
        end
    end

    // counters of the phases (no reset needed beyond the start of a run)
    always_ff @(posedge clk) begin
        if (phase == S_IDLE) begin
            b_asm_cnt <= '0;
            load_idx  <= '0;
            a_pass    <= '0;
            a_slot    <= '0;
            i_pass    <= '0;
            i_slot    <= '0;
            last_kind <= CONTACT;
            int_idx   <= '0;
            credits   <= '0;
            out_cnt   <= '0;
            out_beat  <= '0;
        end else begin
            if (b_done) b_asm_cnt <= b_asm_cnt + 1;
            if (phase == S_LOAD && brec_valid) load_idx <= load_idx + 1;
            if (c_done) begin
                if (a_last) begin
                    a_slot <= '0;
                    a_pass <= a_pass + 1'b1;
                end else begin
                    a_slot <= a_slot + 1;
                end
            end
            if (issue) begin
                last_kind <= rkind;
                if (i_slot == nm - 1) begin
                    i_slot <= '0;
                    i_pass <= i_pass + 1'b1;
                end else begin
                    i_slot <= i_slot + 1;
                end
            end
            if (int_issue) int_idx <= int_idx + 1;
            credits <= credits + 32'(int_issue) - 32'(out_pop);
            if (out_hs) out_beat <= out_pop ? '0 : out_beat + 1'b1;
            if (out_pop) out_cnt <= out_cnt + 1;
        end
    end

    // ---------------- errors ----------------
    always_comb begin
        err_set  = 8'h00;
        err_code = 8'h00;
        if (issue && (hdr_a >= nb || hdr_b >= nb)) begin
            err_set[3] = 1'b1;
            err_code   = 8'h04;
        end
        if (phase == S_IDLE && start && bad_args) begin
            err_set[2] = 1'b1;
            err_code   = 8'h03;
        end
        if (phase == S_LOAD && brec_valid && brec_last != (load_idx == nb - 1)) begin
            err_set[1] = 1'b1;
            err_code   = 8'h02;
        end
        if (crec_valid && issue && crec_last != crec_tag[1]) begin
            err_set[0] = 1'b1;
            err_code   = 8'h01;
        end
    end

    // Not needed (Verilator's *unused* naming convention): the FIFO never fills (an integration issues
    // only with a free credit); the body-in assembler carries no tag; the padding bits of the records;
    // body B's orientation.
    wire unused_seq = ^{i_iter_full[ITER_W], ofifo_full, b_unused_tag, crec[CREC_W-1:64 + 23*W], brec, rd1_data};
endmodule

`default_nettype wire
