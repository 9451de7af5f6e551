// pgs_fifo: synchronous FIFO, DEPTH a power of two, first-word fall-through (the head is read
// asynchronously: distributed RAM on a board). push when !full, pop when !empty.
`default_nettype none

module pgs_fifo #(
    parameter int DATA_W = 32,
    parameter int DEPTH  = 64,
    localparam int PTR_W = $clog2(DEPTH)
) (
    input  wire               clk,
    input  wire               rst,
    input  wire               push,
    input  wire  [DATA_W-1:0] push_data,
    input  wire               pop,
    output logic [DATA_W-1:0] head,
    output logic              empty,
    output logic              full
);
    logic [DATA_W-1:0] mem [DEPTH];
    logic [PTR_W-1:0]  wp, rp;
    logic [PTR_W:0]    count;

    always_ff @(posedge clk) begin
        if (push) mem[wp] <= push_data;
    end
    always_ff @(posedge clk) begin
        if (rst) begin
            wp    <= '0;
            rp    <= '0;
            count <= '0;
        end else begin
            if (push) wp <= wp + 1'b1;
            if (pop) rp <= rp + 1'b1;
            count <= count + (PTR_W+1)'(push) - (PTR_W+1)'(pop);
        end
    end
    assign head  = mem[rp];
    assign empty = count == '0;
    assign full  = count == (PTR_W+1)'(DEPTH);
endmodule

`default_nettype wire
