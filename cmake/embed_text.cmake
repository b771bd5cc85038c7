# embed_text.cmake — a text file as a C string constant, at build time:
#   cmake -DIN=file.cl -DOUT=file_cl.h -DNAME=symbol [-DINLINE=dir/header.h -DINLINE_PATH=/abs/header.h]
#         -P embed_text.cmake
# writes `static const char NAME[] = {bytes..., 0};` (the device kernels are
# compiled by the OpenCL driver at run time, from this string).  With
# INLINE, the line `#include "INLINE"` is replaced by INLINE_PATH's text: a
# header the kernels share with the host's C (src/physics/mc_step.h), for a
# driver that cannot see ohm's files.
if(INLINE)
  file(READ "${IN}" text)
  file(READ "${INLINE_PATH}" header)
  string(FIND "${text}" "#include \"${INLINE}\"" at)
  if(at LESS 0)
    message(FATAL_ERROR "embed_text: ${IN} does not include \"${INLINE}\"")
  endif()
  string(REPLACE "#include \"${INLINE}\"" "${header}" text "${text}")
  file(WRITE "${OUT}.src" "${text}")
  file(READ "${OUT}.src" hex HEX)
  file(REMOVE "${OUT}.src")
else()
  file(READ "${IN}" hex HEX)
endif()
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE "${OUT}.tmp" "/* generated from ${IN} by cmake/embed_text.cmake */\nstatic const char ${NAME}[] = {${bytes}0};\n")
file(RENAME "${OUT}.tmp" "${OUT}")
