/* A diagnosed UR10 model as a binary model (examples/firmware-c/ur10_diagnosed.kcm, written by
   `kinecal export --format firmware`; README.md), included byte for byte; MODEL_FILE is its path
   (set by the Makefile). */
    .section .rodata.diagnosed_kcm, "a"
    .balign 8
    .global diagnosed_kcm_start
    .global diagnosed_kcm_end
diagnosed_kcm_start:
    .incbin MODEL_FILE
diagnosed_kcm_end:
    .section .note.GNU-stack, "", %progbits
