// pgs_run_counters: the run statistics of pgs_sequencer and its floating-point event counters.
//
// Counters (cleared when a run starts: `idle && start`; frozen while idle, after done):
//   * stat_cycles: cycles from start to done inclusive (1 in the start cycle),
//   * stat_stalls / stat_bubbles: cycles with `stall` / `bubble` set,
//   * stat_issued / stat_rejected: manifold-passes issued (`issued`, one bit a lane) and rejected
//     (`rejected`, one bit a lane, plus `fill_rejected`: a missing slot rejected after an early TLAST),
//   * stat_fp_overflow / underflow / invalid: the events of the lanes' solver pipes (`lane_ev`, lane l at
//     [3*EV_W*l +: 3*EV_W], {invalid, underflow, overflow} of EV_W bits each) and of the integrate pipe
//     (`int_ev_*`), counted every cycle (the pipes report after their last input), saturating at 2^32 - 1.
// The stall, bubble, issue and reject counts enter through a register (the take decides them late in its cycle):
// each counter has its cycle's count one cycle later, which a run never sees (those come only in SOLVE, and the
// counters are read once the run is done, cycles after the solve).
// fp_set: {invalid, underflow, overflow} raised this cycle (combinational).
// All are reset by `rst`.
`default_nettype none

module pgs_run_counters #(
    parameter  int LANES    = 1,
    parameter  int EV_W     = 16,                              // width of a pipe's event count
    localparam int EV_SUM_W = EV_W + $clog2(2 * LANES + 2)     // their sum over the lanes and integration
) (
    input  wire                    clk,
    input  wire                    rst,
    input  wire                    idle,
    input  wire                    start,
    input  wire                    stall,
    input  wire                    bubble,
    input  wire  [LANES-1:0]       issued,
    input  wire  [LANES-1:0]       rejected,
    input  wire                    fill_rejected,
    input  wire  [LANES*3*EV_W-1:0] lane_ev,
    input  wire  [EV_W-1:0]        int_ev_ovf,
    input  wire  [EV_W-1:0]        int_ev_unf,
    input  wire  [EV_W-1:0]        int_ev_inv,
    output logic [2:0]             fp_set,       // {invalid, underflow, overflow} events this cycle
    output logic [63:0]            stat_cycles,
    output logic [31:0]            stat_stalls,
    output logic [31:0]            stat_bubbles,
    output logic [31:0]            stat_issued,
    output logic [31:0]            stat_rejected,
    output logic [31:0]            stat_fp_overflow,
    output logic [31:0]            stat_fp_underflow,
    output logic [31:0]            stat_fp_invalid
);
    logic             stall_q, bubble_q, fill_rejected_q;
    logic [LANES-1:0] issued_q, rejected_q;
    always_ff @(posedge clk) begin
        if (rst || idle) begin
            stall_q         <= 1'b0;
            bubble_q        <= 1'b0;
            fill_rejected_q <= 1'b0;
            issued_q        <= '0;
            rejected_q      <= '0;
        end else begin
            stall_q         <= stall;
            bubble_q        <= bubble;
            fill_rejected_q <= fill_rejected;
            issued_q        <= issued;
            rejected_q      <= rejected;
        end
    end

    always_ff @(posedge clk) begin
        if (rst) begin
            stat_cycles   <= '0;
            stat_stalls   <= '0;
            stat_bubbles  <= '0;
            stat_issued   <= '0;
            stat_rejected <= '0;
        end else if (idle) begin
            if (start) begin
                stat_cycles   <= 64'd1;
                stat_stalls   <= '0;
                stat_bubbles  <= '0;
                stat_issued   <= '0;
                stat_rejected <= '0;
            end
        end else begin
            stat_cycles <= stat_cycles + 1'b1;
            if (stall_q)  stat_stalls  <= stat_stalls + 1'b1;
            if (bubble_q) stat_bubbles <= stat_bubbles + 1'b1;
            stat_issued   <= stat_issued + 32'($countones(issued_q));
            stat_rejected <= stat_rejected + 32'($countones(rejected_q)) + 32'(fill_rejected_q);
        end
    end

    // (a lane's sum of its two pipes' counts can wrap only beyond 2^16 events in one cycle: never)
    logic [EV_SUM_W-1:0] ev_ovf, ev_unf, ev_inv;
    always_comb begin
        ev_ovf = EV_SUM_W'(int_ev_ovf);
        ev_unf = EV_SUM_W'(int_ev_unf);
        ev_inv = EV_SUM_W'(int_ev_inv);
        for (int l = 0; l < LANES; l++) begin
            ev_ovf += EV_SUM_W'(lane_ev[3*EV_W*l +: EV_W]);
            ev_unf += EV_SUM_W'(lane_ev[3*EV_W*l + EV_W +: EV_W]);
            ev_inv += EV_SUM_W'(lane_ev[3*EV_W*l + 2*EV_W +: EV_W]);
        end
    end
    assign fp_set = {ev_inv != '0, ev_unf != '0, ev_ovf != '0};

    function automatic logic [31:0] sat_add(input logic [31:0] acc, input logic [EV_SUM_W-1:0] inc);
        logic [32:0] sum;
        sum = {1'b0, acc} + 33'(inc);
        return sum[32] ? '1 : sum[31:0];
    endfunction

    always_ff @(posedge clk) begin
        if (rst || (idle && start)) begin
            stat_fp_overflow  <= '0;
            stat_fp_underflow <= '0;
            stat_fp_invalid   <= '0;
        end else begin
            stat_fp_overflow  <= sat_add(stat_fp_overflow, ev_ovf);
            stat_fp_underflow <= sat_add(stat_fp_underflow, ev_unf);
            stat_fp_invalid   <= sat_add(stat_fp_invalid, ev_inv);
        end
    end
endmodule

`default_nettype wire
