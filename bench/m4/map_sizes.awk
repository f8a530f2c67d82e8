# SPDX-License-Identifier: Apache-2.0
# map_sizes.awk - flash and RAM of each part of a GNU ld map file (the
# -Wl,-Map output of an mps2-an386 image; scripts/m4_bench.sh): the portable
# core (libsp_core.a, per object file), the compiler's and the C library's
# helpers, and the program with its port. Only sections kept in the image
# count (the "Linker script and memory map" part, not the discarded ones).
# By output section: flash = .vectors, .text (code and read-only data),
# .ARM.exidx/extab and the load image of .data; RAM = .data + .bss. Usage: awk -f map_sizes.awk prog.map (POSIX awk).
function hex(s,    v, i, c) {
    v = 0; s = tolower(s); sub(/^0x/, "", s)
    for (i = 1; i <= length(s); ++i) { c = index("0123456789abcdef", substr(s, i, 1)) - 1; v = v * 16 + c }
    return v
}
function part(file) {
    if (file ~ /libsp_core\.a\(/) return "core"
    if (file ~ /libgcc\.a\(/) return "libgcc"
    if (file ~ /libc(_nano)?\.a\(/ || file ~ /libm\.a\(/) return "libc"
    return "program"
}
function add(name, size, file,    p, o, flash, ram) {
    flash = 0; ram = 0
    if (out == ".bss") { ram = size }
    else if (out == ".data") { flash = size; ram = size }
    else if (out == ".vectors" || out == ".text" || out ~ /^\.ARM\.ex/) { flash = size }
    else { return } # the stack, debug information, comments
    p = part(file)
    F[p] += flash; R[p] += ram
    if (p == "core") {
        o = file; sub(/.*\(/, "", o); sub(/\.obj\)$|\.o\)$|\)$/, "", o)
        if (!(o in OF)) { objs[++nobjs] = o }
        OF[o] += flash; OR[o] += ram
    }
}
/^Linker script and memory map/ { inmap = 1; next }
!inmap { next }
/^\./ { out = $1; sec = ""; next } # an output section
/^ \*fill\*/ { next }
/^ [.A-Za-z_]/ {
    # an input section: " name [addr size file]"
    sec = $1
    if (NF >= 4 && $2 ~ /^0x/ && $3 ~ /^0x/) { add(sec, hex($3), $4); sec = "" }
    next
}
/^ +0x/ {
    if (sec != "" && NF >= 3 && $2 ~ /^0x/) { add(sec, hex($2), $3) }
    sec = ""
    next
}
{ sec = "" }
END {
    printf "%-40s %8s %8s\n", "part of the image", "flash", "RAM"
    n = split("core libgcc libc program", order, " ")
    for (i = 1; i <= n; ++i) {
        p = order[i]
        label = (p == "core") ? "portable core (libsp_core.a)" : (p == "libgcc") ? "libgcc (64-bit division, shifts)" : (p == "libc") ? "C library (memcpy, memset...)" : "program, port, semihosting"
        printf "%-40s %8d %8d\n", label, F[p], R[p]
        if (p == "core") {
            for (j = 1; j <= nobjs; ++j) { printf "  %-38s %8d %8d\n", objs[j], OF[objs[j]], OR[objs[j]] }
        }
    }
    printf "%-40s %8d %8d\n", "core + libgcc (what the firmware needs)", F["core"] + F["libgcc"], R["core"] + R["libgcc"]
}
