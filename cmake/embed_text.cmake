# embed_text.cmake — a text file as a C string constant, at build time:
#   cmake -DIN=file.cl -DOUT=file_cl.h -DNAME=symbol -P embed_text.cmake
# writes `static const char NAME[] = {bytes..., 0};` (src/solvers/mg_device.cl's
# kernels are compiled by the OpenCL driver at run time, from this string).
file(READ "${IN}" hex HEX)
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE "${OUT}.tmp" "/* generated from ${IN} by cmake/embed_text.cmake */\nstatic const char ${NAME}[] = {${bytes}0};\n")
file(RENAME "${OUT}.tmp" "${OUT}")
