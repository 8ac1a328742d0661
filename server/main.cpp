// The lipmap binary: subcommands serve / map / classify over the same engine.
int main() { return 0; }
