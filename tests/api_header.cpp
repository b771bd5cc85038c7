/* api_header.cpp — api_header.c compiled as C++ (the header test). */
#define OHM_HEADER_LANGUAGE "C++"
#include "api_header.c"
