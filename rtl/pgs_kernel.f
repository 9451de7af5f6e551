// pgs_kernel.f: every source of the kernel (pgs_kernel), in compile order: packages first, then each module
// after the modules it instantiates. Paths relative to this folder (verilator -F rtl/pgs_kernel.f); read by
// make lint, every Verilator build of the kernel and the Yosys estimate (rtl/gen/file_list.py). A new .sv file
// under rtl/ goes here (a test checks that every one is listed). generated/: written by `make rtl`; generated/xls/
// (the XLS datapath, `make xls`) is not listed: rtl/gen/xls_flow.py swaps its pipes in for a DATAPATH=xls build.

// packages
pgs_fp_pkg.sv
generated/pgs_regs_pkg.sv
generated/pgs_stream_layout_pkg.sv
generated/pgs_pipe_latency_pkg.sv
pgs_seq_pkg.sv

// floating-point operators
fp/fp_unpack.sv
fp/fp_valid_pipe.sv
fp/fp_data_pipe.sv
fp/fp_result_stage.sv
fp/fp_add.sv
fp/fp_mul.sv
fp/fp_div.sv
fp/fp_sqrt.sv
fp/fp_minmax.sv

// datapaths (generated) and their delay lines: the contact and friction pipes, the shared datapaths of both
// passes (SHARED_DATAPATH), the integration
pgs_delay.sv
generated/pgs_contact_pipe.sv
generated/pgs_friction_pipe.sv
generated/pgs_contact_pipe_scalar.sv
generated/pgs_friction_pipe_scalar.sv
generated/pgs_contact_pipe_full.sv
generated/pgs_contact_pipe_soft.sv
generated/pgs_friction_pipe_full.sv
generated/pgs_friction_pipe_mu.sv
generated/pgs_friction_pipe_scalar_mu.sv
generated/pgs_friction_pipe_full_mu.sv
generated/pgs_friction_pipe_tb.sv
generated/pgs_shared_pipe.sv
generated/pgs_shared_pipe_mu.sv
generated/pgs_shared_pipe_scalar.sv
generated/pgs_shared_pipe_scalar_mu.sv
generated/pgs_shared_pipe_full.sv
generated/pgs_shared_pipe_full_mu.sv
generated/pgs_shared_pipe_soft.sv
generated/pgs_shared_pipe_mu_soft.sv
generated/pgs_shared_pipe_tb.sv
generated/pgs_shared_pipe_soft_tb.sv
generated/pgs_integrate_pipe.sv

// memories, queues and control
pgs_fifo.sv
pgs_body_vel_banks.sv
pgs_body_ram.sv
pgs_impulse_ram.sv
pgs_hazard_cam.sv
pgs_record_asm.sv
pgs_ring_ram.sv
pgs_window.sv
pgs_run_counters.sv
pgs_error_flags.sv
pgs_lane_datapath.sv
pgs_seq_load.sv
pgs_seq_records.sv
pgs_seq_issue.sv
pgs_seq_hazards.sv
pgs_seq_lane.sv
pgs_seq_retire.sv
pgs_seq_integrate.sv
pgs_sequencer.sv
pgs_control_s_axi.sv
pgs_kernel.sv
