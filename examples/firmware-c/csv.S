/* The measurement file the Rust firmware streams (examples/firmware/data/measurements.csv),
   included byte for byte; CSV_FILE is its path (set by the Makefile). */
    .section .rodata.measurements_csv, "a"
    .global measurements_csv_start
    .global measurements_csv_end
measurements_csv_start:
    .incbin CSV_FILE
measurements_csv_end:
    .section .note.GNU-stack, "", %progbits
