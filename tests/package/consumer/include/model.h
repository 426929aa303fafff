/* model.h -- the consumer's own header of a common name (C, C++ and GLSL). LSNIF's installed headers
 * must never shadow it, and it must never reach LSNIF's headers (tests/package/consumer). */
#ifndef CONSUMER_OWN_MODEL_H
#define CONSUMER_OWN_MODEL_H 1
#define CONSUMER_OWN_MODEL 1
#endif
