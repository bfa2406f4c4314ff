#include <cstdio>
int main() { std::puts("penumbra"); return 0; }
