/* main.c — the ohm executable. */
#include "cli.h"

int main(int argc, char **argv) { return ohm_cli_main(argc, argv); }
