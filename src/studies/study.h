/* study.h — the studies' command lines (`ohm validate | bench | accuracy`)
 * behind one entry: argv[0] is the study's name.  Tables go to stdout,
 * messages to stderr.  Returns the exit code: 0 done (every check passed),
 * 1 failed, 2 bad usage. */
#ifndef OHM_STUDY_H
#define OHM_STUDY_H

int ohm_study_main(int argc, char **argv, int verbosity);

#endif
