# embed_text.cmake — a text file as a C string constant, at build time:
#   cmake -DIN=file.cl -DOUT=file_cl.h -DNAME=symbol
#         [-DINLINE=dir/a.h,dir/b.h -DINLINE_PATH=/abs/dir/a.h,/abs/dir/b.h] -P embed_text.cmake
# writes `static const char NAME[] = {bytes..., 0};` (the device kernels are
# compiled by the OpenCL driver at run time, from this string).  With
# INLINE (names, comma-separated) and INLINE_PATH (their files, in the same
# order), every line `#include "NAME"` is replaced by that file's text, also
# where an inlined file includes another: headers the kernels share with the
# host's C (src/physics/mc_loop.h and what it includes), for a driver that
# cannot see ohm's files.  Their include guards keep a header given twice to
# one copy.
if(INLINE)
  string(REPLACE "," ";" names "${INLINE}")
  string(REPLACE "," ";" paths "${INLINE_PATH}")
  list(LENGTH names count)
  list(LENGTH paths count_paths)
  if(NOT count EQUAL count_paths)
    message(FATAL_ERROR "embed_text: INLINE names ${count} headers, INLINE_PATH ${count_paths}")
  endif()
  file(READ "${IN}" text)
  math(EXPR last "${count} - 1")
  set(used "")
  # each pass replaces the includes the text holds; an inlined header's own
  # includes are replaced in the next pass
  foreach(pass RANGE 8)
    set(changed 0)
    foreach(i RANGE ${last})
      list(GET names ${i} name)
      list(GET paths ${i} path)
      string(FIND "${text}" "#include \"${name}\"" at)
      if(NOT at LESS 0)
        file(READ "${path}" header)
        string(REPLACE "#include \"${name}\"" "${header}" text "${text}")
        list(APPEND used "${name}")
        set(changed 1)
      endif()
    endforeach()
    if(NOT changed)
      break()
    endif()
  endforeach()
  foreach(name ${names})
    list(FIND used "${name}" found)
    if(found LESS 0)
      message(FATAL_ERROR "embed_text: ${IN} does not include \"${name}\"")
    endif()
  endforeach()
  file(WRITE "${OUT}.src" "${text}")
  file(READ "${OUT}.src" hex HEX)
  file(REMOVE "${OUT}.src")
else()
  file(READ "${IN}" hex HEX)
endif()
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE "${OUT}.tmp" "/* generated from ${IN} by cmake/embed_text.cmake */\nstatic const char ${NAME}[] = {${bytes}0};\n")
file(RENAME "${OUT}.tmp" "${OUT}")
