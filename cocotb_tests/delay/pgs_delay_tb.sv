// pgs_delay_tb: the circular-buffer form of rtl/pgs_delay.sv against its shift-register form, cycle by cycle.
//
// For each line (WIDTH x DEPTH below) both forms get the same random input and the same random valid bit
// every cycle (valid in about 5 of 8 cycles, in runs): the RAM form (RAM_MIN_DEPTH = 2) and the shift
// register (RAM_MIN_DEPTH above DEPTH), with taps at 0, 1, 2, DEPTH / 2, DEPTH - 1 and DEPTH. Once the
// line has been full (DEPTH cycles), every tap whose word was valid must show that word, d of TAPS[k]
// cycles before, in both forms (a history of d and of the valid bit kept here is the reference); a
// difference ends the run with $fatal naming the line, the form, the tap and the cycle. Prints
// "pgs_delay_tb: PASS ..." at the end (cocotb_tests/test_pgs_delay.py builds and runs it).
`default_nettype none

module pgs_delay_tb (
    input wire logic clk   // driven by cocotb_tests/delay/pgs_delay_main.cpp
);
    localparam int N_LINES = 9;
    localparam int N_TAPS  = 6;
    localparam int CYCLES  = 700;
    localparam int DEPTHS [N_LINES] = '{2, 3, 4, 5, 7, 8, 33, 137, 160};
    localparam int WIDTHS [N_LINES] = '{1, 37, 8, 70, 32, 16, 64, 32, 95};

    int cycle = 0;

    function automatic int clamp_tap(int t, int depth);
        return t < 0 ? 0 : (t > depth ? depth : t);
    endfunction

    for (genvar n = 0; n < N_LINES; n++) begin : g_line
        localparam int W = WIDTHS[n];
        localparam int D = DEPTHS[n];
        localparam logic [N_TAPS*32-1:0] TAPS = {32'(D), 32'(D - 1), 32'(D / 2), 32'(clamp_tap(2, D)), 32'(1),
                                                 32'(0)};
        logic [W-1:0]        d;
        logic                v;
        logic [W-1:0]        d_past [1:D];   // d_past[i]: d of i cycles ago (at the sampling edge)
        logic [D:1]          v_past;         // v_past[i]: its valid bit
        logic [W-1:0]        d_hist [0:D];   // d_hist[0] = d, then d_past
        logic [D:0]          v_hist;
        logic [N_TAPS*W-1:0] q_ram, q_shift;

        always @(posedge clk) begin
            d_past[1] <= d;
            v_past[1] <= v;
            for (int i = 2; i <= D; i++) begin
                d_past[i] <= d_past[i-1];
                v_past[i] <= v_past[i-1];
            end
        end
        assign v_hist = {v_past, v};
        always_comb begin
            d_hist[0] = d;
            for (int i = 1; i <= D; i++) d_hist[i] = d_past[i];
        end

        pgs_delay #(.WIDTH(W), .DEPTH(D), .N_TAPS(N_TAPS), .TAPS(TAPS), .RAM_MIN_DEPTH(2)) u_ram (
            .clk(clk), .d(d), .valid(v_hist[D-1:0]), .q(q_ram));
        pgs_delay #(.WIDTH(W), .DEPTH(D), .N_TAPS(N_TAPS), .TAPS(TAPS), .RAM_MIN_DEPTH(D + 1)) u_shift (
            .clk(clk), .d(d), .valid(v_hist[D-1:0]), .q(q_shift));

        always @(negedge clk) begin
            for (int b = 0; b < W; b++) d[b] <= 1'($urandom());
            // runs of valid and idle cycles: the valid bit keeps its value with probability 3/4
            if ($urandom() % 4 == 0) v <= ($urandom() % 8) < 5;
        end
        always @(posedge clk) begin   // sampled before this edge's update
            if (cycle > D + 1) begin
                for (int k = 0; k < N_TAPS; k++) begin
                    automatic int t = int'(TAPS[k*32 +: 32]);
                    if (v_hist[t] && (q_ram[k*W +: W] != d_hist[t] || q_shift[k*W +: W] != d_hist[t])) begin
                        $fatal(1, "pgs_delay_tb: WIDTH %0d DEPTH %0d tap %0d (delay %0d), cycle %0d: RAM %h, shift %h, %s",
                               W, D, k, t, cycle, q_ram[k*W +: W], q_shift[k*W +: W], "expected the valid word");
                    end
                end
            end
        end
    end

    always @(posedge clk) begin
        cycle <= cycle + 1;
        if (cycle == CYCLES) begin
            $display("pgs_delay_tb: PASS %0d lines x %0d taps, %0d cycles", N_LINES, N_TAPS, CYCLES);
            $finish;
        end
    end
endmodule

`default_nettype wire
